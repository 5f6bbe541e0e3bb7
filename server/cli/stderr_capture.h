#pragma once
// Libraries under `serve` write to file descriptor 2 on their own: libpng's default error handler
// prints "libpng error: ..." for a corrupt upload that OpenImageIO then reports properly, Mesa's
// loader prints its warnings. Such a line has no time or level, and a log reader takes it for a
// broken log. While a StderrCapture lives, descriptor 2 is a pipe: each line written there is
// logged as a warning, "stderr: " and the line made printable, and the logger writes to the
// original stderr.
#include <cstdio>
#include <memory>
#include <thread>

namespace textond::cli {

class StderrCapture {
public:
    // nullptr where the pipe or the descriptors cannot be made: stderr then stays as it was.
    static std::unique_ptr<StderrCapture> start();
    // Logs what the pipe still held, restores descriptor 2 and the logger's stderr. Only once
    // the threads that log are gone.
    ~StderrCapture();
    StderrCapture(const StderrCapture&) = delete;
    StderrCapture& operator=(const StderrCapture&) = delete;

private:
    StderrCapture(int read_end, int saved_stderr, std::FILE* log_file);
    static void log_to(std::FILE* file);
    void forward_lines();
    int m_read_end;
    int m_saved_stderr;    // the original stderr, put back on descriptor 2 at the end
    std::FILE* m_log_file; // another copy of it, where the logger writes meanwhile
    std::thread m_reader;
};

} // namespace textond::cli
