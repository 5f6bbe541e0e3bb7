#pragma once
// Splat maps: 2 to 8 texture layers painted over the plane by weights, as terrain engines paint
// their layers. The weights come from an image laid on the plane (RGBA = four layers) or from
// rules on a height field's value and slope; the layers' zero-mean noises are blended so that
// the variance holds where the weights are even (no washed-out greys) and a layer whose weight
// is 1 shows exactly as it is.
#include "core/image.h"
#include "core/result.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace textond::core {

inline constexpr const char* kSplatVersion = "textond-splat/1";
inline constexpr int kMinSplatLayers = 2;
inline constexpr int kMaxSplatLayers = 8;
// A weight image's pixels at most (2048 x 2048, or any shape of as many): 128 MB of floats at 8
// layers, kept while the splat is in use.
inline constexpr std::int64_t kMaxSplatWeightPixels = std::int64_t{1} << 22;

// The seed of layer `layer`: layer 0 keeps the splat's seed (where it alone shows, the splat is
// its texton's tiles), the others draw independent Poisson processes, so that their noises are
// uncorrelated and the blend below keeps the variance.
std::uint64_t splat_layer_seed(std::uint64_t seed, int layer);

// Weights from an image: channel k of `weights` (one channel a layer) is layer k's, placed like
// a mix's mask (core/placed_image.h).
struct SplatImage {
    double x0 = 0, y0 = 0; // texels
    double scale = 1;      // texels per weight pixel
    Image weights;         // values in [0, 1]
};

// Soft band: 1 inside [lo, hi], 0 beyond `soft` outside it, a smoothstep between.
struct SplatBand {
    double lo = -std::numeric_limits<double>::infinity();
    double hi = std::numeric_limits<double>::infinity();
};
double band_weight(const SplatBand& band, double soft, double v);

// Weights from rules on a height field: layer k's weight is its height band times its slope
// band. Height in the height map's units (0..1 for a material set), slope in degrees of the
// surface whose normals map=normal gives at `strength`.
struct SplatRule {
    SplatBand height, slope;
};
struct SplatRules {
    std::vector<SplatRule> layers;
    double height_soft = 0.05; // the height bands' soft edge (map units)
    double slope_soft = 5.0;   // the slope bands' (degrees)
    double strength = 4.0;     // texels spanned by a height step of 1 (render/normal_map.h)
};

struct SplatWeights {
    enum class Kind { image, rules } kind = Kind::image;
    SplatImage image;
    SplatRules rules;
    std::optional<Error> validate(int layers) const;
};

// Raw weights to blend weights: negatives and NaN to 0, then divided by their sum; a point where
// all are 0 shows layer 0 alone. In float, as the renderer computes it for every pixel (the
// renderer's loops run these operations in this order, a pixel per vector lane: the same bits).
inline void normalise_weights(int layers, float* w) {
    float sum = 0.0f;
    for (int k = 0; k < layers; ++k) {
        w[k] = w[k] > 0.0f ? w[k] : 0.0f;
        sum += w[k];
    }
    const bool none = !(sum > 0.0f) || !(sum <= std::numeric_limits<float>::max());
    for (int k = 0; k < layers; ++k) w[k] = none ? (k == 0 ? 1.0f : 0.0f) : w[k] / sum;
}

// Variance-preserving blending (Heitz and Neyret 2018, "High-Performance By-Example Noise using a
// Histogram-Preserving Blending Operator", section 3): with w normalised,
//   v = sum_k w_k m_k + sum_k w_k (v_k - m_k) / sqrt(sum_k w_k^2).
// Independent zero-mean layers of variances s_k^2 give variance sum w_k^2 s_k^2 / sum w_k^2: s^2
// for equal variances at any weights, where a plain linear blend gives s^2 / K at even weights.
//
// In float, in this order: the mean sum w_k m_k, then c_k (v_k - m_k) added for each shown layer
// in layer order, with c_k = w_k / sqrt(sum w^2) (blend_coefficients); a layer whose c_k is 1
// (it alone shows) gives its value itself.
struct BlendCoefficients {
    float c[kMaxSplatLayers];
};
inline BlendCoefficients blend_coefficients(int layers, const float* w) {
    float w2 = 0.0f;
    for (int k = 0; k < layers; ++k) w2 += w[k] * w[k];
    const float s = w2 > 0.0f ? 1.0f / std::sqrt(w2) : 0.0f;
    BlendCoefficients b{};
    for (int k = 0; k < layers; ++k) b.c[k] = w[k] * s;
    return b;
}
float blend_layers(int layers, const float* w, const float* mean, const float* value);

} // namespace textond::core
