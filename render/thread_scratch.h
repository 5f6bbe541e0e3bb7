#pragma once
// Per-thread scratch vectors (a splat's blend) are kept between renders only while small. Every
// connection thread renders, so scratch kept at its largest multiplies by some 150 threads (the
// CPU backend's block scratch did, and now comes from a pool: BlockScratch in cpu_backend.cpp).
// A render that needs more allocates again; its work grows with the size it needs.
#include <cstddef>
#include <vector>

namespace textond::render {

inline constexpr std::size_t kKeptScratchBytes = std::size_t{1} << 20;

template <class T> void release_if_large(std::vector<T>& v) {
    if (v.capacity() * sizeof(T) > kKeptScratchBytes) std::vector<T>().swap(v);
}

} // namespace textond::render
