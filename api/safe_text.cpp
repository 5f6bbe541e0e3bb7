#include "api/safe_text.h"

namespace textond::api {

std::size_t utf8_sequence_length(std::string_view s) {
    if (s.empty()) return 0;
    const auto b = [&](std::size_t i) { return static_cast<unsigned char>(s[i]); };
    const unsigned char c = b(0);
    if (c < 0x80) return 1;
    std::size_t n = 0;
    unsigned char lo = 0x80, hi = 0xbf; // allowed range of the second byte (RFC 3629 table)
    if (c >= 0xc2 && c <= 0xdf) {
        n = 2;
    } else if (c >= 0xe0 && c <= 0xef) {
        n = 3;
        if (c == 0xe0) lo = 0xa0; // overlong
        if (c == 0xed) hi = 0x9f; // UTF-16 surrogates
    } else if (c >= 0xf0 && c <= 0xf4) {
        n = 4;
        if (c == 0xf0) lo = 0x90; // overlong
        if (c == 0xf4) hi = 0x8f; // above U+10FFFF
    } else {
        return 0; // continuation byte, C0/C1 overlong lead, or 0xf5..0xff
    }
    if (s.size() < n || b(1) < lo || b(1) > hi) return 0;
    for (std::size_t i = 2; i < n; ++i)
        if (b(i) < 0x80 || b(i) > 0xbf) return 0;
    return n;
}

std::string printable(std::string_view s, std::size_t max_bytes) {
    static constexpr char kHex[] = "0123456789abcdef";
    constexpr std::string_view kEllipsis = "...";
    std::string out;
    out.reserve(s.size() < max_bytes ? s.size() : max_bytes);
    std::size_t i = 0;
    while (i < s.size()) {
        std::size_t n = utf8_sequence_length(s.substr(i));
        const auto c = static_cast<unsigned char>(s[i]);
        // C1 controls (U+0080..U+009F) are two bytes, c2 80..c2 9f.
        const bool control = (n == 1 && (c < 0x20 || c == 0x7f)) ||
                             (n == 2 && c == 0xc2 && static_cast<unsigned char>(s[i + 1]) < 0xa0);
        std::string piece;
        if (n == 0 || control) {
            const std::size_t bytes = n == 0 ? 1 : n;
            for (std::size_t k = 0; k < bytes; ++k) {
                const auto v = static_cast<unsigned char>(s[i + k]);
                piece += {'\\', 'x', kHex[v >> 4], kHex[v & 15]};
            }
            n = bytes;
        } else {
            piece.assign(s.substr(i, n));
        }
        if (out.size() + piece.size() > max_bytes) {
            // Room for the ellipsis: drop whole pieces, never half a character.
            while (!out.empty() && out.size() + kEllipsis.size() > max_bytes) {
                std::size_t cut = out.size() - 1;
                while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xc0) == 0x80) --cut;
                out.resize(cut);
            }
            if (kEllipsis.size() <= max_bytes) out += kEllipsis;
            return out;
        }
        out += piece;
        i += n;
    }
    return out;
}

} // namespace textond::api
