#pragma once
// Floats to the integers an 8- or 16-bit image file holds: floor(clamp(v, 0, 1) * max + 0.5) in
// float arithmetic, to nearest as OpenImageIO's own conversion and the GL shader round, so every
// backend gives the same bytes. One place for the rule: PNG (image_io.cpp) and WebP / AVIF
// (web_image.cpp).
#include <cstddef>
#include <cstdint>

namespace textond::io {

// out[k * channels + c] = the rule above for planes[c][k], k < n, 1 to 4 channels; a plane may be
// named twice (grey as RGB). NaN gives 0.
void quantise_interleaved(const float* const* planes, int channels, std::size_t n,
                          std::uint8_t* out);
void quantise_interleaved(const float* const* planes, int channels, std::size_t n,
                          std::uint16_t* out);

} // namespace textond::io
