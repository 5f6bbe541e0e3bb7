#pragma once
// Per-thread scratch vectors are kept between renders only while small. Every connection thread
// renders, and libgomp gives each thread that opens a parallel region a team of its own, so
// scratch kept at its largest multiplies by some 150 threads: a replica serving level-3 tiles of a
// small texton (1.2 million points listed a tile) grew to 1.9 GB and stayed there. A render that
// needs more allocates again; its work grows with the size it needs.
#include <cstddef>
#include <vector>

namespace textond::render {

inline constexpr std::size_t kKeptScratchBytes = std::size_t{1} << 20;

template <class T> void release_if_large(std::vector<T>& v) {
    if (v.capacity() * sizeof(T) > kKeptScratchBytes) std::vector<T>().swap(v);
}

} // namespace textond::render
