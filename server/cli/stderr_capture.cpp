#include "server/cli/stderr_capture.h"

#include "api/safe_text.h"
#include "server/cli/commands.h"

#include <spdlog/sinks/ansicolor_sink.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstdio>
#include <fcntl.h>
#include <string>
#include <unistd.h>

namespace textond::cli {

namespace {
// A library that writes without a newline, or a client who makes one write a lot, still gets
// lines of bounded length.
constexpr std::size_t kMaxLine = 2048;

void log_line(const std::string& line) {
    if (!line.empty()) spdlog::warn("stderr: {}", api::printable(line, kMaxLine));
}
} // namespace

std::unique_ptr<StderrCapture> StderrCapture::start() {
    std::fflush(stderr);
    const int saved = ::fcntl(2, F_DUPFD_CLOEXEC, 3);
    if (saved < 0) return nullptr;
    const int for_logger = ::fcntl(2, F_DUPFD_CLOEXEC, 3);
    int ends[2];
    if (for_logger < 0 || ::pipe2(ends, O_CLOEXEC) != 0) {
        if (for_logger >= 0) ::close(for_logger);
        ::close(saved);
        return nullptr;
    }
    std::FILE* log_file = ::fdopen(for_logger, "w");
    if (log_file == nullptr || ::dup2(ends[1], 2) < 0) {
        if (log_file != nullptr) {
            std::fclose(log_file);
        } else {
            ::close(for_logger);
        }
        ::close(ends[0]);
        ::close(ends[1]);
        ::close(saved);
        return nullptr;
    }
    ::close(ends[1]);
    log_to(log_file);
    return std::unique_ptr<StderrCapture>(new StderrCapture(ends[0], saved, log_file));
}

StderrCapture::StderrCapture(int read_end, int saved_stderr, std::FILE* log_file)
    : m_read_end(read_end), m_saved_stderr(saved_stderr), m_log_file(log_file) {
    m_reader = std::thread([this] { forward_lines(); });
}

StderrCapture::~StderrCapture() {
    std::fflush(stderr);
    // The pipe's one write end was descriptor 2: putting stderr back closes it, and the reader
    // sees the end once it has read what was written before.
    ::dup2(m_saved_stderr, 2);
    ::close(m_saved_stderr);
    if (m_reader.joinable()) m_reader.join();
    ::close(m_read_end);
    log_to(stderr);
    std::fclose(m_log_file);
}

void StderrCapture::log_to(std::FILE* file) {
    // Swapped while serve runs no other thread (before the server starts, after it stopped):
    // spdlog's free functions use the default logger without a lock. It keeps its name, level
    // and pattern; only where it writes changes.
    auto old = spdlog::default_logger();
    auto sink = std::make_shared<spdlog::sinks::ansicolor_sink<spdlog::details::console_mutex>>(
        file, spdlog::color_mode::automatic);
    auto logger = std::make_shared<spdlog::logger>(old->name(), std::move(sink));
    logger->set_level(old->level());
    logger->set_pattern(kLogPattern);
    spdlog::set_default_logger(std::move(logger));
}

void StderrCapture::forward_lines() {
    std::string line;
    char buf[4096];
    for (;;) {
        const ssize_t n = ::read(m_read_end, buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        for (ssize_t i = 0; i < n; ++i) {
            if (buf[i] == '\n') {
                log_line(line);
                line.clear();
            } else if (line.size() < kMaxLine) {
                line += buf[i];
            }
        }
    }
    log_line(line);
}

} // namespace textond::cli
