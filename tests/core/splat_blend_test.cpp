// The splat blend (core/splat_blend.h) on synthetic layers: the variance it keeps where a linear
// blend loses it, the mean it takes, a dominant layer shown exactly, and the weights and bands
// that feed it.
#include "core/splat_blend.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <vector>

namespace textond::core {
namespace {

struct Moments {
    double mean = 0, variance = 0;
};

// Blends `n` draws of K independent normal layers (means m_k, sd s_k) with fixed weights.
Moments blended(const std::vector<double>& w_raw, const std::vector<double>& m,
                const std::vector<double>& s, int n, bool linear = false) {
    const int k = static_cast<int>(w_raw.size());
    std::vector<float> w(w_raw.begin(), w_raw.end()), mf(m.begin(), m.end());
    normalise_weights(k, w.data());
    std::mt19937_64 rng(12345);
    std::normal_distribution<double> z;
    double sum = 0, sum2 = 0;
    std::vector<float> v(static_cast<std::size_t>(k));
    for (int i = 0; i < n; ++i) {
        for (int l = 0; l < k; ++l) v[l] = static_cast<float>(m[l] + s[l] * z(rng));
        double b = 0;
        if (linear)
            for (int l = 0; l < k; ++l) b += w[l] * v[l];
        else
            b = blend_layers(k, w.data(), mf.data(), v.data());
        sum += b;
        sum2 += b * b;
    }
    const double mean = sum / n;
    return {mean, sum2 / n - mean * mean};
}

TEST(SplatBlend, KeepsTheVarianceWhereALinearBlendHalvesIt) {
    const int n = 40000;
    // The sample variance of n normals has relative sd sqrt(2 / n) = 0.7%: 5 sd is 3.5%.
    const double tol = 5 * std::sqrt(2.0 / n);
    const std::vector<double> m = {0.2, 0.5, 0.8, 0.4}, s = {0.1, 0.1, 0.1, 0.1};
    for (const std::vector<double>& w :
         {std::vector<double>{1, 1, 1, 1}, {0.5, 0.5, 0, 0}, {0.7, 0.1, 0.15, 0.05}}) {
        const Moments b = blended(w, m, s, n);
        EXPECT_NEAR(b.variance / 0.01, 1.0, tol) << w[0] << " " << w[1];
        // The mean is the weighted mean of the layers' means (sd of the sample mean 0.1/sqrt n).
        std::vector<float> wn(w.begin(), w.end());
        normalise_weights(4, wn.data());
        double want = 0;
        for (int l = 0; l < 4; ++l) want += wn[l] * m[l];
        EXPECT_NEAR(b.mean, want, 5 * 0.1 / std::sqrt(n));
    }
    // What the test would catch: a linear blend at even weights has a quarter of the variance.
    const Moments linear = blended({1, 1, 1, 1}, m, s, n, true);
    EXPECT_NEAR(linear.variance / 0.01, 0.25, tol);
}

TEST(SplatBlend, UnequalVariancesMixAsTheWeightsSquared) {
    // Variance sum w_k^2 s_k^2 / sum w_k^2: weights (3/4, 1/4), sds 0.2 and 0.1 give
    // (9 * 0.04 + 0.01) / 10 = 0.037.
    const int n = 40000;
    const Moments b = blended({3, 1}, {0.5, 0.5}, {0.2, 0.1}, n);
    EXPECT_NEAR(b.variance / 0.037, 1.0, 5 * std::sqrt(2.0 / n));
}

TEST(SplatBlend, ALayerWhoseWeightIsOneShowsExactly) {
    const float w[3] = {0, 1, 0}, m[3] = {0.1f, 0.6f, 0.9f};
    const float v[3] = {std::nanf(""), 0.734f, -5}; // an unrendered layer may hold anything
    EXPECT_EQ(blend_layers(3, w, m, v), 0.734f);
    // Coefficients: w / sqrt(sum w^2), 0 for an absent layer.
    const float even[4] = {0.5f, 0.5f, 0, 0};
    const BlendCoefficients b = blend_coefficients(4, even);
    EXPECT_FLOAT_EQ(b.c[0], std::sqrt(0.5f));
    EXPECT_EQ(b.c[2], 0.0f);
}

TEST(SplatBlend, WeightsAreNormalisedAndNeverEmpty) {
    float w[4] = {2, -1, std::nanf(""), 2};
    normalise_weights(4, w);
    EXPECT_EQ(w[0], 0.5f);
    EXPECT_EQ(w[1], 0.0f);
    EXPECT_EQ(w[2], 0.0f);
    EXPECT_EQ(w[3], 0.5f);
    float none[3] = {0, 0, 0};
    normalise_weights(3, none);
    EXPECT_EQ(none[0], 1.0f); // all zero: the first layer
    EXPECT_EQ(none[1] + none[2], 0.0f);
    float huge[2] = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
    normalise_weights(2, huge); // the sum overflows: the first layer
    EXPECT_EQ(huge[0], 1.0f);
}

TEST(SplatBlend, SoftBands) {
    const SplatBand band{0.3, 0.6};
    EXPECT_EQ(band_weight(band, 0.1, 0.45), 1.0);
    EXPECT_EQ(band_weight(band, 0.1, 0.6), 1.0);
    EXPECT_NEAR(band_weight(band, 0.1, 0.7), 0.0, 1e-12); // the edge's end, up to rounding
    EXPECT_NEAR(band_weight(band, 0.1, 0.2), 0.0, 1e-12);
    EXPECT_EQ(band_weight(band, 0.1, 0.75), 0.0);
    EXPECT_EQ(band_weight(band, 0.1, 0.15), 0.0);
    EXPECT_NEAR(band_weight(band, 0.1, 0.65), 0.5, 1e-12); // half way down the soft edge
    EXPECT_NEAR(band_weight(band, 0.1, 0.25), 0.5, 1e-12);
    double last = 1.0; // monotone down the edge
    for (double v = 0.6; v <= 0.7; v += 0.005) {
        const double b = band_weight(band, 0.1, v);
        EXPECT_LE(b, last + 1e-15);
        last = b;
    }
    EXPECT_EQ(band_weight(SplatBand{}, 0.1, 1e300), 1.0); // unbounded
    EXPECT_EQ(band_weight(band, 0.0, 0.61), 0.0);         // hard edges
    EXPECT_EQ(band_weight(band, 0.1, std::nan("")), 0.0);
}

TEST(SplatBlend, LayerSeedsAreDistinctAndLayerZeroKeepsTheSeed) {
    for (std::uint64_t seed : {0ull, 1ull, 77ull, ~0ull}) {
        EXPECT_EQ(splat_layer_seed(seed, 0), seed);
        std::set<std::uint64_t> seen{seed};
        for (int l = 1; l < kMaxSplatLayers; ++l) seen.insert(splat_layer_seed(seed, l));
        EXPECT_EQ(seen.size(), static_cast<std::size_t>(kMaxSplatLayers)) << seed;
    }
    EXPECT_NE(splat_layer_seed(1, 1), splat_layer_seed(2, 1));
}

TEST(SplatBlend, WeightsAreValidated) {
    SplatWeights w;
    w.image.weights = Image(2, 2, 3, 0.5f);
    EXPECT_FALSE(w.validate(3));
    EXPECT_TRUE(w.validate(2)); // one channel a layer
    EXPECT_TRUE(w.validate(9));
    w.image.scale = 0;
    EXPECT_TRUE(w.validate(3));
    w.image.scale = 1;
    w.image.x0 = std::nan("");
    EXPECT_TRUE(w.validate(3));
    w.image.x0 = 0;
    w.image.weights.data[3] = 1.5f;
    EXPECT_TRUE(w.validate(3));
    SplatWeights r;
    r.kind = SplatWeights::Kind::rules;
    r.rules.layers = {SplatRule{{0, 0.5}, {}}, SplatRule{{0.5, 1}, {0, 30}}};
    EXPECT_FALSE(r.validate(2));
    EXPECT_TRUE(r.validate(3));
    r.rules.layers[1].slope = {40, 30};
    EXPECT_TRUE(r.validate(2));
    r.rules.layers[1].slope = {};
    r.rules.strength = 0;
    EXPECT_TRUE(r.validate(2));
    r.rules.strength = 1001; // map=normal's limit: a splat that could never render
    EXPECT_TRUE(r.validate(2));
    SplatWeights big;
    big.image.weights = Image(2049, 2048, 2, 0.5f); // over 2048 x 2048
    EXPECT_TRUE(big.validate(2));
    // Corner and extent within 2^61, to the texel: at 2^61 a double's step is 512 texels, and
    // 2^61 + 256 had rounded back to 2^61 and passed.
    SplatWeights edge;
    edge.image.weights = Image(256, 1, 2, 0.5f);
    edge.image.x0 = 2305843009213693952.0 - 256; // 2^61 - 256: its far edge is 2^61
    EXPECT_FALSE(edge.validate(2));
    edge.image.x0 = 2305843009213693952.0; // 2^61: its far edge is 2^61 + 256
    EXPECT_TRUE(edge.validate(2));
}

} // namespace
} // namespace textond::core
