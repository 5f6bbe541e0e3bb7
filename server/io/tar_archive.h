#pragma once
// An uncompressed POSIX ustar archive in memory (the engine kit's download). Deterministic: fixed
// mtime, owner and mode, entries in the order given, so the same kit is the same bytes (ETag).
#include "core/result.h"

#include <string>
#include <vector>

namespace textond::io {

struct TarEntry {
    std::string path; // relative, '/'-separated, under 100 bytes, no ".." component
    std::string bytes;
};

Result<std::string> tar_archive(const std::vector<TarEntry>& entries);

} // namespace textond::io
