#include "server/io/upload_bytes.h"

#include <string>

namespace textond::io {

namespace {

Error unprocessable(const std::string& what) {
    return make_error(ErrorCode::unprocessable, what);
}

// A chunk's length, read big-endian at `at`.
std::uint32_t png_chunk_length(std::string_view b, std::size_t at) {
    const auto byte = [&](std::size_t i) {
        return static_cast<std::uint32_t>(static_cast<unsigned char>(b[i]));
    };
    return byte(at) << 24 | byte(at + 1) << 16 | byte(at + 2) << 8 | byte(at + 3);
}

// An EXR channel list whose every channel is a named half, float or uint channel at full
// resolution, ended by a 0 byte inside the attribute. OpenEXR sizes buffers by the sampling
// factors, and a crafted list (found by tests/fuzz) made it take 2 GB for a 96 x 54 image.
bool exr_channels_plain(std::string_view c) {
    std::size_t at = 0;
    while (at < c.size() && c[at] != '\0') {
        const std::size_t end = c.find('\0', at);
        if (end == std::string_view::npos || end - at > 255 || end + 17 > c.size()) return false;
        const auto i32 = [&](std::size_t i) {
            std::uint32_t v = 0;
            for (int k = 3; k >= 0; --k) v = v << 8 | static_cast<unsigned char>(c[i + k]);
            return v;
        };
        const std::uint32_t pixel_type = i32(end + 1); // uint, half, float
        const std::uint32_t x_sampling = i32(end + 9), y_sampling = i32(end + 13);
        if (pixel_type > 2 || x_sampling != 1 || y_sampling != 1) return false;
        at = end + 17;
    }
    return at + 1 == c.size(); // the terminating 0 is the attribute's last byte
}

} // namespace

// Whether every chunk of a PNG lies inside the bytes, up to IEND. OpenImageIO 2.4's PNG reader
// leaks its error string when libpng asks its I/O proxy for bytes past the end (the error
// longjmps over it; found by tests/fuzz), so a truncated PNG is refused before it gets there.
bool png_chunks_complete(std::string_view b) {
    std::size_t at = 8; // signature
    while (at + 12 <= b.size()) {
        const std::uint32_t length = png_chunk_length(b, at);
        if (length > b.size() - at - 12) return false;
        if (b.substr(at + 4, 4) == "IEND") return true;
        at += 12 + length;
    }
    return false;
}

// Chunks are copied whole, their CRCs with them; only the text chunks are left out, and what
// follows IEND (which libpng never reads) too.
std::string png_without_text(std::string_view b) {
    const auto text = [](std::string_view type) {
        return type == "tEXt" || type == "zTXt" || type == "iTXt";
    };
    bool any = false;
    for (std::size_t at = 8; at + 12 <= b.size();) {
        const std::uint32_t length = png_chunk_length(b, at);
        if (length > b.size() - at - 12) break;
        any = any || text(b.substr(at + 4, 4));
        if (b.substr(at + 4, 4) == "IEND") break;
        at += 12 + length;
    }
    if (!any) return {};
    std::string out(b.substr(0, 8));
    for (std::size_t at = 8; at + 12 <= b.size();) {
        const std::uint32_t length = png_chunk_length(b, at);
        if (length > b.size() - at - 12) break;
        const std::string_view type = b.substr(at + 4, 4);
        if (!text(type)) out.append(b.substr(at, 12 + length));
        if (type == "IEND") break;
        at += 12 + length;
    }
    return out;
}

// A JPEG without its metadata segments (APP1..APP13, APP15: Exif, XMP, ICC, IPTC...; COM):
// OpenImageIO 2.4's IPTC parser reads past its buffer on a crafted APP13 segment (a heap overflow
// found by tests/fuzz), and the analysis needs none of them. The segments are walked, not
// decoded; everything from the start of scan on is kept as it is. Empty when the segments do not
// fit the bytes.
std::string jpeg_without_metadata(std::string_view b) {
    std::string out(b.substr(0, 2)); // SOI
    std::size_t at = 2;
    while (at + 2 <= b.size()) {
        if (static_cast<unsigned char>(b[at]) != 0xFF) return {};
        const unsigned char marker = static_cast<unsigned char>(b[at + 1]);
        if (marker == 0xFF) { // fill byte
            ++at;
            continue;
        }
        if (marker == 0xDA) { // start of scan: the entropy-coded data and the rest
            out.append(b.substr(at));
            return out;
        }
        if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) { // no length
            out.append(b.substr(at, 2));
            at += 2;
            continue;
        }
        if (at + 4 > b.size()) return {};
        const std::size_t length = static_cast<std::size_t>(static_cast<unsigned char>(b[at + 2]))
                                       << 8 |
                                   static_cast<unsigned char>(b[at + 3]);
        if (length < 2 || at + 2 + length > b.size()) return {};
        const bool metadata =
            (marker >= 0xE1 && marker <= 0xED) || marker == 0xEF || marker == 0xFE;
        if (!metadata) out.append(b.substr(at, 2 + length));
        at += 2 + length;
    }
    return {};
}

// The scans of a JPEG: its start-of-scan markers up to the end of image, where libjpeg stops
// reading (a phone's motion photo carries a video after it). The markers are read as libjpeg
// reads them: a segment with a length is skipped whole (an 0xFF 0xD9 inside an APP0 or a comment
// ends nothing), and between segments, in entropy-coded data, 0xFF is followed by 0x00, a fill
// byte or a restart marker unless it starts the next marker.
std::size_t jpeg_scans(std::string_view b) {
    const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(b[i]); };
    std::size_t n = 0, at = 2; // after SOI
    while (at + 1 < b.size()) {
        const unsigned char marker = byte(at + 1);
        if (byte(at) != 0xFF || marker == 0xFF) {
            ++at; // entropy-coded data, or a fill byte
        } else if (marker == 0x00 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) {
            at += 2; // a stuffed 0xFF, TEM, a restart marker, SOI: no length
        } else if (marker == 0xD9) {
            break; // end of image
        } else {
            if (at + 4 > b.size()) break;
            const std::size_t length = static_cast<std::size_t>(byte(at + 2)) << 8 | byte(at + 3);
            if (length < 2) break;
            if (marker == 0xDA) ++n;
            at += 2 + length; // a segment, the scan's header included
        }
    }
    return n;
}

// The attributes of an OpenEXR header walked (not decoded) before OpenEXR sees them: OpenEXR 3.1
// allocates whatever size an attribute declares, so 741 bytes declaring a 1.9 GB string took
// 2 GB (found by tests/fuzz). Refuses sizes past the end of the bytes, and data windows over the
// pixel budget, before any allocation.
std::optional<Error> exr_header_check(std::string_view b, std::uint64_t max_pixels) {
    const auto u32 = [&](std::size_t i) {
        std::uint32_t v = 0;
        for (int k = 3; k >= 0; --k) v = v << 8 | static_cast<unsigned char>(b[i + k]);
        return v;
    };
    if (b.size() < 8) return unprocessable("EXR header is truncated");
    const bool multipart = (u32(4) & 0x1000u) != 0;
    std::size_t at = 8;
    for (;;) { // headers (one unless multi-part), each a list of attributes ended by a 0 byte
        if (at >= b.size()) return unprocessable("EXR header is truncated");
        if (b[at] == '\0') {
            if (!multipart || at + 1 >= b.size() || b[at + 1] == '\0') return std::nullopt;
            ++at; // next part's header
            continue;
        }
        const std::size_t name_end = b.find('\0', at);
        const std::size_t type_end = name_end == std::string_view::npos
                                         ? std::string_view::npos
                                         : b.find('\0', name_end + 1);
        if (type_end == std::string_view::npos || name_end - at > 255 ||
            type_end - name_end > 256 || type_end + 5 > b.size())
            return unprocessable("EXR header is truncated or malformed");
        const std::uint32_t size = u32(type_end + 1);
        const std::size_t value = type_end + 5;
        if (size > b.size() - value)
            return unprocessable("EXR attribute declares " + std::to_string(size) +
                                 " bytes, more than the file has");
        const std::string_view name = b.substr(at, name_end - at);
        const std::string_view type = b.substr(name_end + 1, type_end - name_end - 1);
        if (type == "chlist" && !exr_channels_plain(b.substr(value, size)))
            return unprocessable("EXR channel list is malformed or has subsampled channels");
        if (name == "dataWindow" && type == "box2i" && size == 16) {
            const auto i32 = [&](std::size_t i) { return static_cast<std::int32_t>(u32(i)); };
            const std::int64_t w = std::int64_t{i32(value + 8)} - i32(value) + 1;
            const std::int64_t h = std::int64_t{i32(value + 12)} - i32(value + 4) + 1;
            if (w <= 0 || h <= 0) return unprocessable("EXR data window is empty");
            if (static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(h) > max_pixels)
                return make_error(ErrorCode::too_large,
                                  "image is " + std::to_string(w) + "x" + std::to_string(h) +
                                      " pixels, over the budget of " + std::to_string(max_pixels));
        }
        at = value + size;
    }
}

} // namespace textond::io
