#include "server/io/tar_archive.h"

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace textond::io {

namespace {

constexpr std::size_t kBlock = 512;

// Octal, zero-padded to width - 1 digits and a NUL (the ustar numeric field convention).
void octal(char* field, std::size_t width, unsigned long long v) {
    std::snprintf(field, width, "%0*llo", static_cast<int>(width - 1), v);
}

bool safe_path(const std::string& p) {
    if (p.empty() || p.size() >= 100 || p.front() == '/') return false;
    std::size_t start = 0;
    while (start <= p.size()) {
        const std::size_t end = std::min(p.find('/', start), p.size());
        const std::string part = p.substr(start, end - start);
        if (part.empty() || part == "." || part == "..") return false;
        start = end + 1;
    }
    return true;
}

} // namespace

Result<std::string> tar_archive(const std::vector<TarEntry>& entries) {
    std::string out;
    for (const TarEntry& e : entries) {
        if (!safe_path(e.path))
            return make_error(ErrorCode::invalid_argument, "tar: bad entry path " + e.path);
        char h[kBlock];
        std::memset(h, 0, kBlock);
        std::copy_n(e.path.data(), e.path.size(), h); // name (fixed width: no NUL needed)
        octal(h + 100, 8, 0644);                      // mode
        octal(h + 108, 8, 0);                         // uid
        octal(h + 116, 8, 0);                         // gid
        octal(h + 124, 12, e.bytes.size());           // size
        octal(h + 136, 12, 0);                        // mtime: fixed, for equal bytes
        h[156] = '0';                                 // regular file
        std::copy_n("ustar", 6, h + 257);             // magic with its NUL
        std::copy_n("00", 2, h + 263);                // version (fixed width, no NUL)
        std::copy_n("textond", 7, h + 265);           // uname (the header is zeroed)
        std::copy_n("textond", 7, h + 297);           // gname
        // The checksum is taken with its own field as eight spaces.
        std::memset(h + 148, ' ', 8);
        unsigned sum = 0;
        for (unsigned char c : h) sum += c;
        std::snprintf(h + 148, 8, "%06o", sum);
        h[155] = ' ';
        out.append(h, kBlock);
        out += e.bytes;
        out.append((kBlock - e.bytes.size() % kBlock) % kBlock, '\0');
    }
    out.append(2 * kBlock, '\0'); // end-of-archive marker
    return out;
}

} // namespace textond::io
