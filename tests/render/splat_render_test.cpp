// Splat maps rendered (Renderer::splat): the blend of real texton windows keeps each layer's
// variance where the weights are even, shows a layer exactly where it alone has weight, places the
// weight image on the plane, follows rules on a height field, is one function for every window
// (strips included), and agrees with OpenGL as a texton does.
#include "render/prepared_splat.h"
#include "render/renderer.h"
#include "tests/render/render_fixtures.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

std::unique_ptr<render::Renderer> renderer(render::BackendKind kind = render::BackendKind::cpu) {
    render::BackendOptions o;
    o.threads = 2;
    auto r = render::Renderer::make(kind, o);
    return r ? std::move(r.value()) : nullptr;
}

// Image weights: a w x h image of `layers` channels filled by f(c, x, y).
core::SplatWeights image_weights(int layers, int w, int h, double scale,
                                 const std::function<float(int, int, int)>& f) {
    core::SplatWeights s;
    s.image.scale = scale;
    s.image.weights = core::Image(w, h, layers);
    for (int c = 0; c < layers; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) s.image.weights.at(c, x, y) = f(c, x, y);
    return s;
}

std::shared_ptr<const render::PreparedSplat>
splat(std::vector<std::shared_ptr<const render::PreparedTexton>> layers, core::SplatWeights w,
      std::shared_ptr<const render::PreparedTexton> height = nullptr) {
    auto s = render::PreparedSplat::make(std::move(layers), std::move(w), std::move(height));
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
    return s ? s.value() : nullptr;
}

double channel_variance(const core::Image& img, int c) {
    double s = 0, s2 = 0;
    const auto n = static_cast<double>(img.plane_size());
    for (std::size_t i = 0; i < img.plane_size(); ++i) {
        s += img.plane(c)[i];
        s2 += double(img.plane(c)[i]) * img.plane(c)[i];
    }
    return s2 / n - (s / n) * (s / n);
}

TEST(SplatRender, EvenWeightsKeepEachLayersVariance) {
    auto r = renderer();
    const auto sand = analysed_texton("etr_sand01.png", 32);
    // Two layers of one texton at even weights: independent seeds, so a linear blend would have
    // half the variance and the variance-preserving one all of it.
    auto s = splat({sand, sand}, image_weights(2, 1, 1, 1, [](int, int, int) { return 0.5f; }));
    render::NoiseRequest q;
    q.level = 2; // r = 32 spans 8 pixels: about 64^2 independent patches in 512^2
    q.width = q.height = 512;
    q.seed = 3;
    auto blended = r->splat(*s, q, render::Renderer::Work::frame);
    ASSERT_TRUE(blended.ok()) << blended.error().message;
    render::NoiseRequest alone = q;
    alone.seed = 11;
    auto layer = r->noise(*sand, alone, render::Renderer::Work::frame);
    ASSERT_TRUE(layer.ok());
    for (int c = 0; c < 3; ++c) {
        // A sample variance over ~4096 independent patches: relative sd ~2%; 5 sd of the ratio
        // of two is ~15%.
        const double ratio =
            channel_variance(blended.value(), c) / channel_variance(layer.value(), c);
        EXPECT_NEAR(ratio, 1.0, 0.15) << "channel " << c;
        EXPECT_GT(ratio, 0.75) << "a linear blend's 0.5 would pass here";
    }
}

TEST(SplatRender, ALayerAloneIsItsTextonsTilesAndTheWeightImageSitsWhereItWasPut) {
    auto r = renderer();
    const auto sand = analysed_texton("etr_sand01.png", 16);
    const auto gravel = analysed_texton("skimage_gravel.png", 16); // grey
    // Two weight pixels of 64 texels from x0 = -64: layer 0 on the left, layer 1 on the right,
    // bilinear between the pixel centres (texels -32 and 32), clamped beyond them.
    auto w = image_weights(2, 2, 1, 64, [](int c, int x, int) { return c == x ? 1.0f : 0.0f; });
    w.image.x0 = -64;
    w.image.y0 = -1000;
    auto s = splat({sand, gravel}, w);
    ASSERT_EQ(s->channels(), 3);
    render::NoiseRequest q;
    q.seed = 5;
    q.x0 = -100;
    q.y0 = 7;
    q.width = 200;
    q.height = 20;
    auto got = r->splat(*s, q, render::Renderer::Work::frame);
    ASSERT_TRUE(got.ok());
    auto left = r->noise(*sand, q, render::Renderer::Work::frame);
    render::NoiseRequest q1 = q;
    q1.seed = core::splat_layer_seed(5, 1);
    auto right = r->noise(*gravel, q1, render::Renderer::Work::frame);
    ASSERT_TRUE(left.ok() && right.ok());
    for (int y = 0; y < q.height; ++y)
        for (int x = 0; x < q.width; ++x) {
            const std::int64_t tx = q.x0 + x;
            for (int c = 0; c < 3; ++c) {
                if (tx <= -33) {
                    ASSERT_EQ(got.value().at(c, x, y), left.value().at(c, x, y)) << tx;
                } else if (tx >= 32) {
                    ASSERT_EQ(got.value().at(c, x, y), right.value().at(0, x, y)) << tx;
                }
            }
        }
    // Between the centres both show, blended by core::blend_layers at the pixel's weights.
    auto weights = r->splat_weights(*s, q, render::Renderer::Work::frame);
    ASSERT_TRUE(weights.ok());
    for (int x = 68; x < 132; x += 7) { // texels -32 .. 31
        const float wt[2] = {weights.value().at(0, x, 3), weights.value().at(1, x, 3)};
        EXPECT_NEAR(wt[1], static_cast<double>(q.x0 + x + 32) / 64.0, 1e-6);
        for (int c = 0; c < 3; ++c) {
            const float m[2] = {static_cast<float>(sand->texton().mean[c]),
                                static_cast<float>(gravel->texton().mean[0])};
            const float v[2] = {left.value().at(c, x, 3), right.value().at(0, x, 3)};
            EXPECT_EQ(got.value().at(c, x, 3), core::blend_layers(2, wt, m, v));
        }
    }
}

// Every layer count: the renderer's vector loops against core::blend_layers, pixel by pixel,
// on weights that cross every case (one layer alone, none but layer 1, zeros, uneven mixes).
TEST(SplatRender, EveryLayerCountIsCoresBlendBitForBit) {
    auto r = renderer();
    const auto sand = analysed_texton("etr_sand01.png", 16);
    const auto gravel = analysed_texton("skimage_gravel.png", 16);
    for (int k = 3; k <= core::kMaxSplatLayers; ++k) {
        std::vector<std::shared_ptr<const render::PreparedTexton>> layers;
        for (int l = 0; l < k; ++l) layers.push_back(l % 3 == 1 ? gravel : sand);
        auto w = image_weights(k, 5, 4, 7, [k](int c, int x, int y) {
            const int v = (c * 7 + x * 3 + y * 5 + k) % 6;
            return v < 2 ? 0.0f : static_cast<float>(v) / 5.0f; // a third are 0
        });
        w.image.weights.at(0, 1, 1) = 0; // a texel of zeros: layer 1 alone
        for (int c = 1; c < k; ++c) w.image.weights.at(c, 1, 1) = 0;
        auto s = splat(layers, w);
        render::NoiseRequest q;
        q.seed = 13;
        q.x0 = -3;
        q.width = 40;
        q.height = 30;
        auto got = r->splat(*s, q, render::Renderer::Work::tile);
        auto weights = r->splat_weights(*s, q, render::Renderer::Work::tile);
        ASSERT_TRUE(got.ok() && weights.ok());
        std::vector<core::Image> v;
        for (int l = 0; l < k; ++l) {
            render::NoiseRequest lq = q;
            lq.seed = core::splat_layer_seed(q.seed, l);
            v.push_back(
                r->noise(*layers[static_cast<std::size_t>(l)], lq, render::Renderer::Work::tile)
                    .value());
        }
        int mismatches = 0;
        for (int y = 0; y < q.height; ++y)
            for (int x = 0; x < q.width; ++x)
                for (int c = 0; c < 3; ++c) {
                    float wt[core::kMaxSplatLayers], m[core::kMaxSplatLayers],
                        val[core::kMaxSplatLayers];
                    for (int l = 0; l < k; ++l) {
                        const auto& layer = *layers[static_cast<std::size_t>(l)];
                        const int lc = std::min(c, layer.channels() - 1);
                        wt[l] = weights.value().at(l, x, y);
                        m[l] =
                            static_cast<float>(layer.texton().mean[static_cast<std::size_t>(lc)]);
                        val[l] = v[static_cast<std::size_t>(l)].at(lc, x, y);
                    }
                    mismatches += got.value().at(c, x, y) != core::blend_layers(k, wt, m, val);
                }
        EXPECT_EQ(mismatches, 0) << k << " layers";
    }
}

TEST(SplatRender, OneFunctionForEveryWindowStripsIncluded) {
    auto r = renderer();
    const auto sand = analysed_texton("etr_sand01.png", 16);
    const auto pebbles = analysed_texton("etr_pebbles04.png", 16);
    const auto gravel = analysed_texton("skimage_gravel.png", 16);
    auto w = image_weights(3, 3, 3, 40, [](int c, int x, int y) {
        return static_cast<float>(((c + 1) * (x + 2) + y * 5) % 7) / 6.0f;
    });
    w.image.x0 = 13;
    auto s = splat({sand, pebbles, gravel}, w);
    for (int level : {-1, 0, 2, 6}) {
        render::NoiseRequest q;
        q.seed = 9;
        q.level = level;
        q.x0 = -40;
        q.y0 = 10;
        q.width = q.height = 96;
        EXPECT_EQ(first_tile_off_the_region(
                      [&](const render::NoiseRequest& t) {
                          return r->splat(*s, t, render::Renderer::Work::tile);
                      },
                      q),
                  -1)
            << "level " << level;
    }
    // A window over 2^20 pixels goes in strips of 2^20 / width rows: the rows on both sides of
    // the first boundary equal a window of their own.
    render::NoiseRequest big;
    big.level = 5; // the limit model: cheap
    big.width = 2048;
    big.height = 520;
    auto whole = r->splat(*s, big, render::Renderer::Work::frame);
    ASSERT_TRUE(whole.ok());
    render::NoiseRequest part = big;
    part.y0 = 500;
    part.height = 20;
    auto rows = r->splat(*s, part, render::Renderer::Work::frame);
    ASSERT_TRUE(rows.ok());
    EXPECT_EQ(max_abs_diff(rows.value(), window(whole.value(), 0, 500, 2048, 20)), 0.0);
}

TEST(SplatRender, RulesFollowTheHeightAndTheSlope) {
    auto r = renderer();
    const auto set = pebble_set(16, 1);
    auto height = render::map_view(set, core::kNormalMap); // the set's height map
    ASSERT_TRUE(height.ok());
    const auto sand = analysed_texton("etr_sand01.png", 16);
    const auto gravel = analysed_texton("skimage_gravel.png", 16);
    core::SplatWeights w;
    w.kind = core::SplatWeights::Kind::rules;
    const double mid = height.value()->texton().mean[0];
    w.rules.height_soft = 0;
    w.rules.slope_soft = 0;
    w.rules.strength = 8;
    // Layer 0 below the mean height, layer 1 above it where the slope is under 20 degrees,
    // layer 2 on every slope over 20 degrees.
    w.rules.layers = {core::SplatRule{{-1e9, mid}, {}}, core::SplatRule{{mid, 1e9}, {0, 20}},
                      core::SplatRule{{}, {20, 90}}};
    auto s = splat({sand, gravel, sand}, w, height.value());
    render::NoiseRequest q;
    q.seed = 4;
    q.width = q.height = 64;
    auto weights = r->splat_weights(*s, q, render::Renderer::Work::frame);
    auto h = r->noise(*height.value(), q, render::Renderer::Work::frame);
    auto n = r->normals(*height.value(), q, 8, render::Renderer::Work::frame);
    ASSERT_TRUE(weights.ok() && h.ok() && n.ok());
    int shown[3] = {0, 0, 0};
    for (int y = 0; y < q.height; ++y)
        for (int x = 0; x < q.width; ++x) {
            const double hv = h.value().at(0, x, y);
            const double slope = std::acos(2.0 * n.value().at(2, x, y) - 1.0) * 180 / M_PI;
            const double want[3] = {hv <= mid ? 1.0 : 0.0, hv >= mid && slope <= 20 ? 1.0 : 0.0,
                                    slope >= 20 ? 1.0 : 0.0};
            double sum = want[0] + want[1] + want[2];
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(weights.value().at(k, x, y), want[k] / sum, 1e-6)
                    << x << "," << y << " h " << hv << " slope " << slope;
            for (int k = 0; k < 3; ++k) shown[k] += weights.value().at(k, x, y) > 0.5f;
        }
    // The rules split this window: every layer dominates somewhere.
    for (int k = 0; k < 3; ++k) EXPECT_GT(shown[k], 0) << "layer " << k;
}

TEST(SplatRender, RefusesWhatItCannotDraw) {
    auto r = renderer();
    const auto sand = analysed_texton("etr_sand01.png", 16);
    auto s = splat({sand, sand}, image_weights(2, 1, 1, 1, [](int, int, int) { return 1.0f; }));
    render::NoiseRequest q;
    q.period = {2, 2};
    EXPECT_EQ(r->splat(*s, q, render::Renderer::Work::tile).error().code,
              ErrorCode::invalid_argument);
    q.period = {0, 0};
    q.marginals = render::Marginals::exemplar;
    EXPECT_EQ(r->splat(*s, q, render::Renderer::Work::tile).error().code,
              ErrorCode::invalid_argument);
    EXPECT_FALSE(render::PreparedSplat::make(
                     {sand}, image_weights(1, 1, 1, 1, [](int, int, int) { return 1.0f; }))
                     .ok());
    EXPECT_FALSE(
        render::PreparedSplat::make({sand, pebble_set(16, 1)},
                                    image_weights(2, 1, 1, 1, [](int, int, int) { return 1.0f; }))
            .ok()); // a material set is not a layer
}

// The blend runs on the CPU for every backend; the layers come from OpenGL as texton windows
// do, so the splat agrees with the CPU's within the texton bound (gl_backend_test.cpp).
TEST(SplatRender, OsmesaAgreesWithCpu) {
    auto gl = renderer(render::BackendKind::osmesa);
    if (!gl) GTEST_SKIP() << "no OSMesa";
    auto cpu = renderer();
    const auto sand = analysed_texton("etr_sand01.png", 32);
    const auto pebbles = analysed_texton("etr_pebbles04.png", 32);
    auto w = image_weights(2, 2, 2, 50,
                           [](int c, int x, int y) { return static_cast<float>((c + x + y) % 2); });
    auto s = splat({sand, pebbles}, w);
    for (int level : {0, 2, -1}) {
        render::NoiseRequest q;
        q.seed = 21;
        q.level = level;
        q.x0 = -30;
        q.width = 120;
        q.height = 90;
        auto a = cpu->splat(*s, q, render::Renderer::Work::tile);
        std::string used;
        auto b = gl->splat(*s, q, render::Renderer::Work::tile, &used);
        ASSERT_TRUE(a.ok() && b.ok());
        EXPECT_EQ(used, "osmesa");
        const double tol = 1e-5 * std::max(field_std(*sand, 0), field_std(*pebbles, 0));
        EXPECT_LE(max_abs_diff(a.value(), b.value()), 4 * tol) << "level " << level;
    }
}

} // namespace
} // namespace textond::test
