#include "server/io/atomic_file.h"

#include "server/io/crash_point.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <sys/stat.h>
#include <unistd.h>

namespace textond::io {

namespace fs = std::filesystem;

namespace {
std::mutex g_no_space_mutex;
std::optional<std::pair<std::chrono::steady_clock::time_point, std::string>> g_no_space;
} // namespace

std::optional<std::string> recent_no_space(std::chrono::seconds within) {
    std::lock_guard lock(g_no_space_mutex);
    if (!g_no_space || std::chrono::steady_clock::now() > g_no_space->first + within)
        return std::nullopt;
    return g_no_space->second;
}

std::vector<std::string> remove_unfinished_writes(const std::string& dir) {
    std::vector<std::string> removed;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        const auto tmp = name.rfind(".tmp-");
        if (name.size() < 2 || name[0] != '.' || tmp == std::string::npos || tmp == 0) continue;
        std::error_code rm;
        if (fs::remove(it->path(), rm)) removed.push_back(name);
    }
    return removed;
}

Result<std::unique_ptr<AtomicFile>> AtomicFile::create(const std::string& path) {
    const fs::path target(path);
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::string tmp = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
    const int fd = mkstemp(tmp.data());
    if (fd < 0) return failure(path, errno); // no room for one more file is full too
    return std::unique_ptr<AtomicFile>(new AtomicFile(path, tmp, fd));
}

AtomicFile::AtomicFile(std::string path, std::string tmp, int fd)
    : m_path(std::move(path)), m_tmp(std::move(tmp)), m_fd(fd) {}

AtomicFile::~AtomicFile() {
    if (m_fd >= 0) ::close(m_fd);
    if (!m_committed) ::unlink(m_tmp.c_str());
}

Error AtomicFile::failure(const std::string& path, int err) {
    const bool full = err == ENOSPC || err == EDQUOT || err == EFBIG;
    Error e{full ? ErrorCode::no_space : ErrorCode::io,
            "cannot write " + path + ": " + std::strerror(err)};
    if (full) {
        std::lock_guard lock(g_no_space_mutex);
        g_no_space.emplace(std::chrono::steady_clock::now(), e.message);
    }
    return e;
}

Result<bool> AtomicFile::write(std::string_view bytes) {
    std::size_t off = 0;
    while (off < bytes.size()) {
        const ssize_t n = ::write(m_fd, bytes.data() + off, bytes.size() - off);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return failure(m_path, n == 0 ? ENOSPC : errno);
        off += static_cast<std::size_t>(n);
    }
    m_size += bytes.size();
    return true;
}

Result<bool> AtomicFile::commit(const char* crash_ext) {
    bool ok = ::fchmod(m_fd, 0644) == 0 && ::fsync(m_fd) == 0;
    const int saved = errno;
    ok = (::close(m_fd) == 0) && ok;
    m_fd = -1;
    if (!ok) return failure(m_path, saved);
    if (crash_ext) crash_point(std::string(crash_ext) + "-written");
    if (std::rename(m_tmp.c_str(), m_path.c_str()) != 0) return failure(m_path, errno);
    m_committed = true;
    if (crash_ext) crash_point(std::string(crash_ext) + "-renamed");
    return true;
}

} // namespace textond::io
