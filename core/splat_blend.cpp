#include "core/splat_blend.h"

#include "core/material_set.h"
#include "core/noise_hash.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace textond::core {

std::uint64_t splat_layer_seed(std::uint64_t seed, int layer) {
    if (layer == 0) return seed;
    using noise::absorb;
    using noise::mix32;
    const std::uint32_t h = absorb(mix32(noise::lo32(seed) ^ 0x3c6ef372u), noise::hi32(seed));
    const std::uint32_t a = absorb(h, static_cast<std::uint32_t>(layer));
    const std::uint32_t b = absorb(a, 0xa54ff53au);
    return (std::uint64_t{a} << 32) | b;
}

double band_weight(const SplatBand& band, double soft, double v) {
    if (std::isnan(v)) return 0.0;
    auto smooth = [](double t) {
        t = std::clamp(t, 0.0, 1.0);
        return t * t * (3.0 - 2.0 * t);
    };
    if (!(soft > 0.0)) return v >= band.lo && v <= band.hi ? 1.0 : 0.0;
    const double rise = std::isinf(band.lo) ? 1.0 : smooth((v - (band.lo - soft)) / soft);
    const double fall = std::isinf(band.hi) ? 1.0 : smooth(((band.hi + soft) - v) / soft);
    return rise * fall;
}

std::optional<Error> SplatWeights::validate(int layers) const {
    auto bad = [](const std::string& m) { return make_error(ErrorCode::invalid_argument, m); };
    if (layers < kMinSplatLayers || layers > kMaxSplatLayers)
        return bad("a splat has 2 to 8 layers");
    if (kind == Kind::image) {
        const SplatImage& s = image;
        // The weights lie within half the plane (|x|, |y| <= 2^61 texels, render/NOISE_SPEC.md),
        // so that every window of them, the report's which shows them whole included, lies
        // within the plane (a splat at x0 = 2^62 was made, and its own quality link was 400).
        const double lim = 2305843009213693952.0; // 2^61
        if (!std::isfinite(s.scale) || s.scale < 1.0 / 16 || s.scale > 1e9)
            return bad("scale must be in [1/16, 1e9] texels per weight pixel");
        // The far edge in long double: at 2^61 a double's step is 512 texels, and x0 = 2^61
        // plus an extent of 256 rounded back to 2^61 and passed.
        const long double w = static_cast<long double>(s.weights.width) * s.scale,
                          h = static_cast<long double>(s.weights.height) * s.scale;
        if (!std::isfinite(s.x0) || !std::isfinite(s.y0) || s.x0 < -lim || s.y0 < -lim ||
            s.x0 + w > lim || s.y0 + h > lim)
            return bad("the weights must lie within |x|, |y| <= 2^61 texels (x0 and y0 place "
                       "their corner; width and height times scale their extent)");
        if (std::int64_t{s.weights.width} * s.weights.height > kMaxSplatWeightPixels)
            return bad(
                "a weight image has at most 4194304 pixels (2048 x 2048, or any shape of as many)");
        if (s.weights.width < 1 || s.weights.height < 1 || s.weights.channels != layers)
            return bad("the weights have " + std::to_string(s.weights.channels) + " channels for " +
                       std::to_string(layers) + " layers (one a layer)");
        for (float v : s.weights.data)
            if (!(v >= 0.0f && v <= 1.0f)) return bad("weights must be numbers in [0, 1]");
        return std::nullopt;
    }
    const SplatRules& r = rules;
    if (static_cast<int>(r.layers.size()) != layers)
        return bad("the rules have " + std::to_string(r.layers.size()) + " layers for " +
                   std::to_string(layers) + " textons");
    for (const SplatRule& l : r.layers)
        for (const SplatBand* b : {&l.height, &l.slope})
            if (std::isnan(b->lo) || std::isnan(b->hi) || b->lo > b->hi)
                return bad("a band is [lo, hi] with lo <= hi");
    if (!std::isfinite(r.height_soft) || r.height_soft < 0 || !std::isfinite(r.slope_soft) ||
        r.slope_soft < 0)
        return bad("soft edges are finite and not negative");
    if (!(r.strength > 0 && r.strength <= kMaxNormalStrength))
        return bad("strength must be in (0, 1000] (as map=normal's)");
    return std::nullopt;
}

float blend_layers(int layers, const float* w, const float* mean, const float* value) {
    float v = 0.0f;
    for (int k = 0; k < layers; ++k) v += w[k] * mean[k];
    const BlendCoefficients b = blend_coefficients(layers, w);
    for (int k = 0; k < layers; ++k) {
        if (b.c[k] == 0.0f) continue; // a layer left unrendered may hold anything
        v = b.c[k] == 1.0f ? value[k] : v + b.c[k] * (value[k] - mean[k]);
    }
    return v;
}

} // namespace textond::core
