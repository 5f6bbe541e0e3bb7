#pragma once
// The integer hash and random stream of texton noise (render/NOISE_SPEC.md, section 2). Written
// for 32-bit words only so that GLSL (render/glsl/noise_lib.glsl) computes the same bits.
#include <cstdint>

namespace textond::core::noise {

constexpr std::uint32_t mix32(std::uint32_t x) {
    // "lowbias32" (C. Wellons): a bijection with low avalanche bias.
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

constexpr std::uint32_t absorb(std::uint32_t h, std::uint32_t w) {
    return mix32(h ^ w);
}
constexpr std::uint32_t lo32(std::uint64_t v) {
    return static_cast<std::uint32_t>(v);
}
constexpr std::uint32_t hi32(std::uint64_t v) {
    return static_cast<std::uint32_t>(v >> 32);
}

// Key of grid cell (cx, cy): the seed first, through bijections, so every seed bit changes every
// cell (the authors' shader added the seed to the cell index).
constexpr std::uint32_t cell_key(std::uint64_t seed, std::int64_t cx, std::int64_t cy) {
    const auto ux = static_cast<std::uint64_t>(cx), uy = static_cast<std::uint64_t>(cy);
    std::uint32_t h = mix32(lo32(seed) ^ 0x6a09e667u);
    h = absorb(h, hi32(seed));
    h = absorb(h, lo32(ux));
    h = absorb(h, hi32(ux));
    h = absorb(h, lo32(uy));
    return absorb(h, hi32(uy));
}

// Key of output pixel (px, py) at level k, for the limit model's white noise.
constexpr std::uint32_t pixel_key(std::uint64_t seed, int level, std::int64_t px, std::int64_t py) {
    const auto ux = static_cast<std::uint64_t>(px), uy = static_cast<std::uint64_t>(py);
    std::uint32_t h = mix32(lo32(seed) ^ 0xbb67ae85u);
    h = absorb(h, hi32(seed));
    h = absorb(h, static_cast<std::uint32_t>(level));
    h = absorb(h, lo32(ux));
    h = absorb(h, hi32(ux));
    h = absorb(h, lo32(uy));
    return absorb(h, hi32(uy));
}

// A Weyl sequence through mix32: cheap, stateless apart from one word, the same on a GPU.
class Stream32 {
public:
    explicit constexpr Stream32(std::uint32_t key) : m_state(key) {}
    constexpr std::uint32_t next() {
        m_state += 0x9e3779b9u;
        return mix32(m_state);
    }

private:
    std::uint32_t m_state;
};

} // namespace textond::core::noise
