#pragma once
// A progress bar on stderr for long commands: redrawn in place (at most ten times a second) on a
// terminal; one line per tenth of the work in a log.
#include <chrono>
#include <cstdint>
#include <string>

namespace textond::cli {

class ProgressBar {
public:
    // `done` of `total` are already done (a resumed job): the rate counts only new ones.
    ProgressBar(std::string label, std::uint64_t total, std::uint64_t done, bool quiet);
    void update(std::uint64_t done);
    void finish();

private:
    void draw(bool last);
    using Clock = std::chrono::steady_clock;
    std::string m_label;
    std::uint64_t m_total, m_start, m_done;
    bool m_quiet, m_tty;
    Clock::time_point m_t0, m_drawn;
    int m_tenths = -1; // the last tenth logged, without a terminal
};

} // namespace textond::cli
