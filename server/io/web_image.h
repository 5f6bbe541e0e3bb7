#pragma once
// Tiles for browsers and web pipelines: WebP (lossless, or lossy at a quality) through libwebp
// and AVIF through libavif, from the same 8-bit values the PNG tiles hold (each channel clamped
// to [0, 1], times 255, rounded), so a lossless WebP decodes to the PNG's pixels exactly. Grey
// images are written as RGB with equal channels (neither format has a grey mode).
#include "core/image.h"
#include "core/result.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace textond::io {

inline constexpr int kDefaultAvifQuality = 80; // AVIF is lossy only

// Interleaved 8-bit RGB, all that the encoders read: a caller may free the float image once it
// has this (a quarter of its bytes), and each encoder frees it once the codec holds its own copy.
struct Rgb8 {
    int width = 0, height = 0;
    std::vector<std::uint8_t> pixels;
};
Result<Rgb8> to_rgb8(const core::Image& image);
// The same, taking an RGB image's 8-bit bytes (core::Image::bytes: left empty) rather than
// copying them.
Result<Rgb8> take_rgb8(core::Image& image);

// `quality` in [1, 100]; 0: lossless. `stop`, asked as the encoder goes, abandons it (cancelled):
// the client of a large WebP left (libavif has no such hook: an AVIF runs to its end).
Result<std::string> encode_webp(Rgb8 rgb, int quality, const std::function<bool()>& stop = {});
Result<std::string> encode_webp(const core::Image& image, int quality);
// `quality` in [1, 100] (100: the finest quantiser, not lossless).
Result<std::string> encode_avif(Rgb8 rgb, int quality);
Result<std::string> encode_avif(const core::Image& image, int quality);

} // namespace textond::io
