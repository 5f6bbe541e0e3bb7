#pragma once
// An upload's bytes walked (never decoded) before a decoder sees them: each container's
// segments, chunks or attributes checked against the bytes it has, and what the analysis does
// not need taken out where a decoder mishandles it (tests/fuzz and the hostile tests found each).
#include "core/result.h"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace textond::io {

// Whether every chunk of a PNG lies inside `b`, up to IEND.
bool png_chunks_complete(std::string_view b);

// The PNG without its text chunks (tEXt, zTXt, iTXt), or empty when it has none. libpng inflates
// each compressed one (up to 8 MB) and keeps up to 1000 of them, and OpenImageIO reads them all
// on open: a 3 MB upload took 3 GiB before its first pixel. The analysis reads no text.
std::string png_without_text(std::string_view b);

// A JPEG without its metadata segments; empty when its segments do not fit the bytes.
std::string jpeg_without_metadata(std::string_view b);

// The start-of-scan markers of a JPEG up to its end of image.
std::size_t jpeg_scans(std::string_view b);

// An OpenEXR header's attributes checked before OpenEXR allocates what they declare.
std::optional<Error> exr_header_check(std::string_view b, std::uint64_t max_pixels);

} // namespace textond::io
