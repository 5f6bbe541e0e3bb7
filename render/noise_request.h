#pragma once
// What a backend evaluates: one window of the texton noise of render/NOISE_SPEC.md.
#include <array>
#include <cstdint>

namespace textond::render {

class Cancel;

// Part of every tile's identity (ETag): bump it whenever NOISE_SPEC.md changes a pixel.
inline constexpr const char* kNoiseVersion = "textond-noise/1";

inline constexpr double kDefaultMni = 30.0;
inline constexpr int kMaxWindowSide = 16384;
inline constexpr std::int64_t kMaxWindowPixels = std::int64_t{1} << 26;
// The plane is [-2^62, 2^62] texels: at level k >= 0 that is 2^62 / 2^k output pixels.
inline constexpr std::int64_t kPlaneHalfWidth = std::int64_t{1} << 62;

// The bits the caller keeps of each value: a GL backend rounds on the GPU and reads back only
// those (as the encoder rounds: clamp to [0, 1], scale, + 0.5, truncate), then hands back floats
// that encode to the same bytes, or at 8 bits the bytes themselves (NoiseRequest::bytes). The CPU
// backend always returns full floats.
enum class Precision { f32, u16, u8 };

// gaussian: the noise as it is; exemplar: each pixel mapped onto the exemplar's marginals
// (core/marginals.h), after the evaluation, on every backend.
enum class Marginals { gaussian, exemplar };

struct NoiseRequest {
    std::uint64_t seed = 0;
    double mni = kDefaultMni;
    int level = 0; // -4..24: 2^level texels per output pixel
    std::int64_t x0 = 0, y0 = 0;
    int width = 256, height = 256;
    std::array<std::int64_t, 2> period{0, 0}; // tileable mode, in cells; 0 = unbounded plane
    Marginals marginals = Marginals::gaussian;
    Precision precision = Precision::f32; // not part of the window: what the caller keeps
    // With precision u8, and not part of the window either: the caller takes the bytes themselves
    // (core::Image::bytes, interleaved) from a backend that reads back only those (GL); the CPU
    // backend and GL's float paths (exemplar marginals) still return floats.
    bool bytes = false;
    // Not part of the window: when to give up (render/cancel.h); none = run to the end.
    const Cancel* cancel = nullptr;
};

// The output pixel p's position in texels at `level`: the point it samples (k <= 0) or the
// centre of its footprint (k > 0), where a mix takes its mean colour and a splat its weights.
inline double pixel_texel(int level, std::int64_t p) {
    if (level > 0) {
        const std::int64_t st = std::int64_t{1} << level;
        return static_cast<double>(st * p) + 0.5 * static_cast<double>(st - 1);
    }
    return static_cast<double>(p) / static_cast<double>(std::int64_t{1} << -level);
}

// What an evaluation cost, in units that do not depend on the machine (tests compare them).
struct RenderStats {
    std::uint64_t points = 0;      // Poisson points generated
    std::uint64_t evaluations = 0; // (pixel, point) kernel evaluations, or limit-model taps
    // (an abandoned exact render still reports what it did before it stopped)
    bool limit_model = false;
    double gpu_ms = -1; // GPU time of the dispatches (GL timer queries); -1 on the CPU
};

} // namespace textond::render
