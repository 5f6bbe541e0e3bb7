#pragma once
// Reused pixel buffers for renders. `serve` maps every allocation over 128 kB on its
// own (so that cached tiles go back to the system when evicted), which made each cold tile's
// 786 kB float image a fresh mapping: page faults and zero fills were a third of the server's
// CPU per tile. Renders give their images back after encoding; a process-wide pool keeps at most
// kMaxSpares of them of each kind (floats, and the bytes of 8-bit GL tiles), each at most
// kMaxSpareBytes, 32 MiB in all, for the next renders.
#include "core/image.h"

#include <cstddef>

namespace textond::render {

inline constexpr std::size_t kMaxSpares = 8;
inline constexpr std::size_t kMaxSpareBytes = std::size_t{4} << 20;

// An image of w x h x c whose pixels the caller will all write (not zeroed when reused).
core::Image take_image(int width, int height, int channels);
// The same with 8-bit interleaved pixels (core::Image::bytes), from a pool of their own.
core::Image take_bytes_image(int width, int height, int channels);
// Gives `image`'s pixels (floats or bytes) back to the pool (kept when small enough and the pool
// has room).
void recycle_image(core::Image&& image);

} // namespace textond::render
