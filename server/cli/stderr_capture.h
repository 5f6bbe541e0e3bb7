#pragma once
// Libraries under `serve` write to file descriptor 2 on their own: libpng's default error handler
// prints "libpng error: ..." for a corrupt upload that OpenImageIO then reports properly, Mesa's
// loader prints its warnings. Such a line has no time or level, and a log reader takes it for a
// broken log. While a StderrCapture lives, descriptor 2 is a pipe read by a child process, which
// logs each line as a warning, "stderr: " and the line made printable (at any --log-level), to
// the original stderr; the server's own logger writes there directly.
//
// A child and not a thread: what the server writes just before it dies (an uncaught exception's
// "terminate called...", glibc's "malloc(): corrupted ...", an LLVM error before exit) is still
// in the pipe when the process is gone, and only a reader outside it can pass it on. The child
// reads until the last write end closes, when the server exits however it exits.
//
// A child killed on its own (an operator's kill, the OOM killer) is reaped within 0.2 s, a warning
// says so, and descriptor 2 is the original stderr again: a library's lines go there as they are
// rather than into a pipe nobody reads.
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <sys/types.h>
#include <thread>

namespace textond::cli {

class StderrCapture {
public:
    // nullptr where the pipe, the descriptors or the child cannot be made: stderr then stays as
    // it was. Call it while the process has one thread (the child is a fork).
    static std::unique_ptr<StderrCapture> start();
    // Restores descriptor 2 and the logger's stderr, and waits (at most 2 s) for the child to
    // pass on what the pipe still held. Only once the threads that log are gone.
    ~StderrCapture();
    StderrCapture(const StderrCapture&) = delete;
    StderrCapture& operator=(const StderrCapture&) = delete;

private:
    StderrCapture(pid_t child, std::FILE* log_file) : m_child(child), m_log_file(log_file) {}
    static void log_to(std::FILE* file);
    void watch_child();
    pid_t m_child;
    std::FILE* m_log_file; // a copy of the original stderr, where the logger writes meanwhile
    std::mutex m_mutex;
    std::condition_variable m_wake;
    bool m_stopping = false;
    bool m_reaped = false;
    std::thread m_watcher;
};

} // namespace textond::cli
