#pragma once
// A file written in pieces that appears whole or not at all: a temporary beside the target,
// fsynced and renamed over it by commit(); dropped (unlinked) when commit is never reached. For
// outputs too large to hold in memory (tile archives); write_file_atomic is the one-piece case.
#include "core/result.h"

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace textond::io {

// The message of the last write (of any AtomicFile, so of every stored file) refused for lack of
// space (ENOSPC, EDQUOT, EFBIG) within `within`; /readyz says it, since its own probe of a few
// bytes still fits on a disk too full for a texton.
std::optional<std::string> recent_no_space(std::chrono::seconds within);

// The temporaries that writes a crash interrupted left in `dir` (".<name>.tmp-XXXXXX", never
// renamed, so never part of a stored object): removed, and their names returned for the log. For
// a store opening its directory, before any write of its own.
std::vector<std::string> remove_unfinished_writes(const std::string& dir);

class AtomicFile {
public:
    static Result<std::unique_ptr<AtomicFile>> create(const std::string& path);
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // Appends; a full disk is no_space, other failures io.
    Result<bool> write(std::string_view bytes);
    // fsync, then rename over the target. With `crash_ext`, passes the crash points
    // "<ext>-written" and "<ext>-renamed" on the way (crash_point.h).
    Result<bool> commit(const char* crash_ext = nullptr);
    std::uint64_t size() const { return m_size; }

private:
    AtomicFile(std::string path, std::string tmp, int fd);
    static Error failure(const std::string& path, int err);
    std::string m_path, m_tmp;
    int m_fd = -1;
    std::uint64_t m_size = 0;
    bool m_committed = false;
};

} // namespace textond::io
