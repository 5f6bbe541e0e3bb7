#pragma once
// Tiles for browsers and web pipelines: WebP (lossless, or lossy at a quality) through libwebp
// and AVIF through libavif, from the same 8-bit values the PNG tiles hold (each channel clamped
// to [0, 1], times 255, rounded), so a lossless WebP decodes to the PNG's pixels exactly. Grey
// images are written as RGB with equal channels (neither format has a grey mode).
#include "core/image.h"
#include "core/result.h"

#include <string>

namespace textond::io {

inline constexpr int kDefaultAvifQuality = 80; // AVIF is lossy only

// `quality` in [1, 100]; 0: lossless.
Result<std::string> encode_webp(const core::Image& image, int quality);
// `quality` in [1, 100] (100: the finest quantiser, not lossless).
Result<std::string> encode_avif(const core::Image& image, int quality);

} // namespace textond::io
