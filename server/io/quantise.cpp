#include "server/io/quantise.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

// Compiled with -fno-trapping-math (server/io/CMakeLists.txt): without it GCC keeps the clamp's
// branches, as if a float-to-int conversion could raise an exception someone reads, and the
// loop stays scalar: 0.59 ms for a 256 x 256 RGB tile against 0.11 vectorised, on a development
// machine. The flag changes no value, only what the compiler may assume about FP exceptions.
namespace textond::io {

namespace {
// A few kB a plane: the quantised planes stay in L1 while they are interleaved.
constexpr std::size_t kChunk = 2048;

template <class T>
void quantise_plane(const float* __restrict in, std::size_t m, T* __restrict out) {
    constexpr float kMax = std::numeric_limits<T>::max();
    for (std::size_t i = 0; i < m; ++i) {
        float v = in[i];
        v = v > 0.0f ? v : 0.0f; // NaN fails the test: 0, defined before the conversion
        v = v < 1.0f ? v : 1.0f;
        // Never negative here, so +0.5 rounds to nearest.
        // NOLINTNEXTLINE(bugprone-incorrect-roundings)
        out[i] = static_cast<T>(static_cast<std::int32_t>(v * kMax + 0.5f));
    }
}

template <class T, int NC>
void quantise_chunks(const float* const* planes, std::size_t n, T* __restrict out) {
    alignas(64) T q[NC][kChunk];
    for (std::size_t k0 = 0; k0 < n; k0 += kChunk) {
        const std::size_t m = std::min(kChunk, n - k0);
        for (int c = 0; c < NC; ++c) quantise_plane(planes[c] + k0, m, q[c]);
        T* __restrict o = out + k0 * NC;
        for (std::size_t i = 0; i < m; ++i)
            for (int c = 0; c < NC; ++c) o[i * NC + c] = q[c][i];
    }
}

template <class T>
void quantise_any(const float* const* planes, int channels, std::size_t n, T* out) {
    switch (channels) {
    case 1:
        return quantise_chunks<T, 1>(planes, n, out);
    case 2:
        return quantise_chunks<T, 2>(planes, n, out);
    case 3:
        return quantise_chunks<T, 3>(planes, n, out);
    case 4:
        return quantise_chunks<T, 4>(planes, n, out);
    default:
        throw std::invalid_argument("quantise: 1 to 4 channels");
    }
}
} // namespace

void quantise_interleaved(const float* const* planes, int channels, std::size_t n,
                          std::uint8_t* out) {
    quantise_any(planes, channels, n, out);
}

void quantise_interleaved(const float* const* planes, int channels, std::size_t n,
                          std::uint16_t* out) {
    quantise_any(planes, channels, n, out);
}

} // namespace textond::io
