#include "server/cli/progress_bar.h"

#include <algorithm>
#include <cstdio>
#include <unistd.h>

namespace textond::cli {

ProgressBar::ProgressBar(std::string label, std::uint64_t total, std::uint64_t done, bool quiet)
    : m_label(std::move(label)), m_total(total), m_start(done), m_done(done), m_quiet(quiet),
      m_tty(::isatty(STDERR_FILENO) == 1), m_t0(Clock::now()), m_drawn(m_t0) {}

void ProgressBar::update(std::uint64_t done) {
    m_done = done;
    if (m_quiet) return;
    const auto now = Clock::now();
    if (m_tty) {
        if (now - m_drawn < std::chrono::milliseconds(100)) return;
    } else {
        const int tenths = m_total ? static_cast<int>(10 * m_done / m_total) : 10;
        if (tenths == m_tenths) return;
        m_tenths = tenths;
    }
    m_drawn = now;
    draw(false);
}

void ProgressBar::finish() {
    if (m_quiet || (!m_tty && m_tenths == 10)) return; // a log already has the last line
    draw(true);
}

void ProgressBar::draw(bool last) {
    const double s = std::chrono::duration<double>(Clock::now() - m_t0).count();
    const double rate = s > 0 ? static_cast<double>(m_done - m_start) / s : 0.0;
    const double frac = m_total ? static_cast<double>(m_done) / static_cast<double>(m_total) : 1;
    constexpr int kWidth = 30;
    std::string bar(kWidth, ' ');
    std::fill_n(bar.begin(), static_cast<int>(frac * kWidth), '=');
    char eta[32] = "";
    if (rate > 0 && m_done < m_total)
        std::snprintf(eta, sizeof eta, "  eta %.0f s",
                      static_cast<double>(m_total - m_done) / rate);
    std::fprintf(stderr, "%s%s [%s] %3.0f%%  %llu/%llu  %.1f/s%s%s", m_tty ? "\r" : "",
                 m_label.c_str(), bar.c_str(), 100 * frac, static_cast<unsigned long long>(m_done),
                 static_cast<unsigned long long>(m_total), rate, eta, m_tty ? "\033[K" : "\n");
    if (m_tty && last) std::fputc('\n', stderr);
    std::fflush(stderr);
}

} // namespace textond::cli
