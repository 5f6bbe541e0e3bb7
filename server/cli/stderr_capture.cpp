#include "server/cli/stderr_capture.h"

#include "api/safe_text.h"
#include "server/cli/commands.h"

#include <spdlog/sinks/ansicolor_sink.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <chrono>
#include <fcntl.h>
#include <string>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace textond::cli {

namespace {
// A library that writes without a newline, or a client who makes one write a lot, still gets
// lines of bounded length (cut with "...").
constexpr std::size_t kMaxLine = 2048;

std::shared_ptr<spdlog::logger> logger_on(std::FILE* file, const std::string& name) {
    auto sink = std::make_shared<spdlog::sinks::ansicolor_sink<spdlog::details::console_mutex>>(
        file, spdlog::color_mode::automatic);
    auto logger = std::make_shared<spdlog::logger>(name, std::move(sink));
    logger->set_pattern(kLogPattern);
    return logger;
}

// The child: reads the pipe to its end and logs each line on `out`, then leaves without running
// the parent's exit handlers.
[[noreturn]] void forward_lines(int pipe_end, int out) {
    ::prctl(PR_SET_NAME, "textond-stderr"); // its name in ps -o comm, top and pgrep
    const int null = ::open("/dev/null", O_RDWR | O_CLOEXEC);
    if (null >= 0) {
        ::dup2(null, 0);
        ::dup2(null, 1); // the server's stdout closes when the server goes, not when this does
    }
    std::FILE* file = ::fdopen(out, "w");
    if (file == nullptr) ::_exit(1);
    auto logger = logger_on(file, spdlog::default_logger()->name());
    logger->set_level(spdlog::level::trace); // the server's --log-level never hides these
    std::string line;
    auto emit = [&] {
        if (!line.empty()) logger->warn("stderr: {}", api::printable(line, kMaxLine));
        line.clear();
    };
    char buf[4096];
    for (;;) {
        const ssize_t n = ::read(pipe_end, buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        for (ssize_t i = 0; i < n; ++i) {
            if (buf[i] == '\n') {
                emit();
            } else if (line.size() <= kMaxLine) {
                line += buf[i];
            }
        }
    }
    emit();
    std::fflush(file);
    ::_exit(0);
}
} // namespace

std::unique_ptr<StderrCapture> StderrCapture::start() {
    std::fflush(stderr);
    const int saved = ::fcntl(2, F_DUPFD_CLOEXEC, 3);
    if (saved < 0) return nullptr;
    const int for_logger = ::fcntl(2, F_DUPFD_CLOEXEC, 3);
    int ends[2] = {-1, -1};
    if (for_logger < 0 || ::pipe2(ends, O_CLOEXEC) != 0) {
        if (for_logger >= 0) ::close(for_logger);
        ::close(saved);
        return nullptr;
    }
    std::FILE* log_file = ::fdopen(for_logger, "w");
    const pid_t child = log_file != nullptr ? ::fork() : -1;
    if (child == 0) {
        ::close(ends[1]);
        std::fclose(log_file);
        forward_lines(ends[0], saved);
    }
    ::close(ends[0]);
    ::close(saved);
    if (child < 0 || ::dup2(ends[1], 2) < 0) {
        if (log_file != nullptr) {
            std::fclose(log_file);
        } else {
            ::close(for_logger);
        }
        ::close(ends[1]);
        if (child > 0) ::waitpid(child, nullptr, 0); // it reads to the end: the pipe is closed
        return nullptr;
    }
    ::close(ends[1]);
    log_to(log_file);
    std::unique_ptr<StderrCapture> capture(new StderrCapture(child, log_file));
    capture->m_watcher = std::thread([c = capture.get()] { c->watch_child(); });
    return capture;
}

void StderrCapture::watch_child() {
    std::unique_lock<std::mutex> lock(m_mutex);
    while (!m_stopping) {
        int status = 0;
        if (::waitpid(m_child, &status, WNOHANG) == m_child) {
            m_reaped = true;
            ::dup2(::fileno(m_log_file), 2);
            const std::string how = WIFSIGNALED(status)
                                        ? "killed by signal " + std::to_string(WTERMSIG(status))
                                        : "exit " + std::to_string(WEXITSTATUS(status));
            spdlog::warn("stderr: its reader textond-stderr (pid {}) ended ({}); a library's lines "
                         "go to stderr as they are from now on",
                         m_child, how);
            return;
        }
        m_wake.wait_for(lock, std::chrono::milliseconds(200));
    }
}

StderrCapture::~StderrCapture() {
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        m_stopping = true;
    }
    m_wake.notify_all();
    if (m_watcher.joinable()) m_watcher.join(); // not when its thread could not be made
    std::fflush(stderr);
    // Descriptor 2 was the pipe's one write end here: putting stderr back closes it, and the
    // child passes on what was written before and exits.
    ::dup2(::fileno(m_log_file), 2);
    log_to(stderr);
    std::fclose(m_log_file);
    // A descendant that kept the write end would keep the child reading: it is not waited for
    // past 2 s (it exits when that end closes, and init reaps it).
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (!m_reaped && ::waitpid(m_child, nullptr, WNOHANG) == 0 &&
           std::chrono::steady_clock::now() < until)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

void StderrCapture::log_to(std::FILE* file) {
    // Swapped while serve runs no other thread (before the server starts, after it stopped):
    // spdlog's free functions use the default logger without a lock. It keeps its name and
    // level; only where it writes changes.
    auto old = spdlog::default_logger();
    auto logger = logger_on(file, old->name());
    logger->set_level(old->level());
    spdlog::set_default_logger(std::move(logger));
}

} // namespace textond::cli
