// Spatially varying texton noise (texton-noise section 7) on the CPU backend: the mixed field's
// statistics at both ends, its continuity across level boundaries, and the usual one function,
// many windows.
#include "render/cpu_backend.h"
#include "tests/render/render_fixtures.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

namespace textond::test {
namespace {

using render::CpuBackend;
using render::NoiseRequest;

constexpr double kSigmas = 4.5;
const std::int64_t kFar = std::int64_t{1} << 40;

core::MixField ramp_x(double x0, double width) {
    core::MixField f;
    f.x0 = x0;
    f.width = width;
    return f;
}

// Far on the rho = 0 side the field is u's texture (mean m_u, variance C_u); far on the rho = 1
// side it is v's. The variances are the models' own (the colour correction makes every level's
// noise covariance equal to its model's), so the bound is sampling error alone.
TEST(TextureMixNoise, EndsReproduceTheTwoTexturesStatistics) {
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 21, ramp_x(0, 4096));
    CpuBackend cpu;
    for (int end : {0, 1}) {
        const auto& tex = mix->level(end == 0 ? 0 : mix->levels() - 1);
        std::vector<double> mean[3], var[3];
        for (int w = 0; w < 24; ++w) {
            NoiseRequest q;
            q.seed = 100 + static_cast<std::uint64_t>(w);
            q.x0 = end == 0 ? -kFar + w * 10000 : kFar - w * 10000;
            q.y0 = w * 7919;
            q.width = q.height = 64;
            auto img = cpu.render_mix(*mix, q);
            ASSERT_TRUE(img.ok()) << img.error().message;
            for (int c = 0; c < 3; ++c) {
                double s1 = 0, s2 = 0;
                const float* p = img.value().plane(c);
                for (std::size_t k = 0; k < img.value().plane_size(); ++k) {
                    s1 += p[k];
                    s2 += double(p[k]) * p[k];
                }
                const double n = static_cast<double>(img.value().plane_size());
                const double m = tex.texton().mean[static_cast<std::size_t>(c)];
                mean[c].push_back(s1 / n);
                var[c].push_back(s2 / n - 2 * m * s1 / n + m * m); // about the model's mean
            }
        }
        for (int c = 0; c < 3; ++c) {
            const Estimate em = estimate_of(mean[c]), ev = estimate_of(var[c]);
            EXPECT_NEAR(em.mean, tex.texton().mean[static_cast<std::size_t>(c)], kSigmas * em.se)
                << "end " << end << " channel " << c;
            EXPECT_NEAR(ev.mean, tex.covariance()->at(c, c, 0, 0), kSigmas * ev.se)
                << "end " << end << " channel " << c;
        }
    }
}

// Points take the level of the field at their own position and every kernel is continuous, so
// across the boundary x_b between two levels the local variance and gradient energy change
// smoothly. With 3 levels (far apart: a jump would be large) the difference between the two
// pixel columns at either side of x_b must match the same difference in the middle of a level,
// within sampling bounds plus the smooth trend over one column (a fraction of the level step).
TEST(TextureMixNoise, NoJumpAcrossLevelBoundaries) {
    const double span = 512; // texels per level
    const auto mix =
        analysed_mix("mypaint_HR_DecoPaper.png", "skimage_gravel.png", 32, 3, ramp_x(0, 2 * span));
    CpuBackend cpu;
    const double var0 = mix->level(0).covariance()->at(1, 1, 0, 0);
    const double var1 = mix->level(1).covariance()->at(1, 1, 0, 0);
    // Gradient energy E[(f(x + e1) - f(x))^2 + (f(x + e2) - f(x))^2] = 2 (2 C(0) - C(e1) - C(e2)).
    auto grad = [&](int l) {
        const auto held = mix->level(l).covariance();
        const core::LagCovariance& cov = *held;
        return 2 * (2 * cov.at(1, 1, 0, 0) - cov.at(1, 1, 1, 0) - cov.at(1, 1, 0, 1));
    };
    const double grad0 = grad(0), grad1 = grad(1);
    // Local statistics of the two columns left and right of x (x the first column on the right).
    auto columns = [&](std::int64_t x, std::vector<double>& dvar, std::vector<double>& dgrad) {
        for (int w = 0; w < 48; ++w) {
            NoiseRequest q;
            q.seed = 7 + static_cast<std::uint64_t>(w);
            q.x0 = x - 2;
            q.y0 = w * 100003;
            q.width = 4;
            q.height = 256;
            auto img = cpu.render_mix(*mix, q);
            ASSERT_TRUE(img.ok());
            double v[2] = {0, 0}, g[2] = {0, 0};
            for (int y = 0; y + 1 < q.height; ++y)
                for (int side = 0; side < 2; ++side) {
                    const int col = 1 + side; // columns x - 1 and x
                    const double m = mix->mean_at(double(q.x0 + col), double(q.y0 + y), 1);
                    const double f = img.value().at(1, col, y) - m;
                    v[side] += f * f;
                    const double gy = img.value().at(1, col, y + 1) - img.value().at(1, col, y);
                    const double gx =
                        side == 0 ? img.value().at(1, col, y) - img.value().at(1, col - 1, y)
                                  : img.value().at(1, col + 1, y) - img.value().at(1, col, y);
                    g[side] += gx * gx + gy * gy;
                }
            dvar.push_back((v[1] - v[0]) / (q.height - 1));
            dgrad.push_back((g[1] - g[0]) / (q.height - 1));
        }
    };
    std::vector<double> bv, bg, cv, cg;
    // Level 0 -> 1 switches at rho = 1/4: x = span / 2. Control: the middle of level 1 (x = span).
    columns(static_cast<std::int64_t>(span / 2), bv, bg);
    columns(static_cast<std::int64_t>(span), cv, cg);
    const Estimate b_var = estimate_of(bv), c_var = estimate_of(cv), b_grad = estimate_of(bg),
                   c_grad = estimate_of(cg);
    std::printf("levels 0 -> 1 variance %.3g -> %.3g, gradient energy %.3g -> %.3g; column step at "
                "the boundary %.3g +- %.2g, "
                "mid-level %.3g +- %.2g; gradient energy step %.3g +- %.2g vs %.3g +- %.2g\n",
                var0, var1, grad0, grad1, b_var.mean, b_var.se, c_var.mean, c_var.se, b_grad.mean,
                b_grad.se, c_grad.mean, c_grad.se);
    // The test has power: a jump (pixels switching level at once) would be the whole level step.
    ASSERT_GT(std::fabs(var1 - var0), 10 * std::hypot(b_var.se, c_var.se));
    ASSERT_GT(std::fabs(grad1 - grad0), 10 * std::hypot(b_grad.se, c_grad.se));
    // The blend spans the kernel's width r = 32 texels: one column carries ~1/16 of the step.
    EXPECT_LT(std::fabs(b_var.mean - c_var.mean),
              kSigmas * std::hypot(b_var.se, c_var.se) + std::fabs(var1 - var0) / 16);
    EXPECT_LT(std::fabs(b_grad.mean - c_grad.mean),
              kSigmas * std::hypot(b_grad.se, c_grad.se) + std::fabs(grad1 - grad0) / 16);
}

// One function, many windows: 2x2 tiles equal the region bit for bit, at levels -1, 0, 2 and
// the limit model, straddling level boundaries.
TEST(TextureMixNoise, TilesStitchBitExactly) {
    core::MixField f = ramp_x(-40, 200);
    f.dy = 1; // diagonal
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 21, f);
    CpuBackend cpu(2, 40);
    for (int level : {-1, 0, 2, mix->level(0).limit_level()}) {
        NoiseRequest q;
        q.seed = 3;
        q.level = level;
        q.x0 = -64;
        q.y0 = -32;
        q.width = q.height = 128;
        EXPECT_EQ(first_tile_off_the_region(
                      [&](const NoiseRequest& r) { return cpu.render_mix(*mix, r); }, q),
                  -1)
            << "level " << level;
    }
    NoiseRequest tileable;
    tileable.period = {2, 2};
    EXPECT_TRUE(mix->check(tileable).has_value()); // tileable mixes are not defined
}

// A mask places the two textures: mean colour of u where the mask is black, of v where white.
TEST(TextureMixNoise, MaskPlacesTheTextures) {
    core::MixField f;
    f.kind = core::MixField::Kind::mask;
    f.mask = core::Image(2, 1, 1);
    f.mask.at(0, 1, 0) = 1.0f;
    f.scale = 1024; // left half [0, 1024) black, right half [1024, 2048) white
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 16, 5, f);
    CpuBackend cpu;
    for (int side : {0, 1}) {
        NoiseRequest q;
        q.x0 = side == 0 ? 0 : 1536;
        q.width = q.height = 256;
        auto img = cpu.render_mix(*mix, q);
        ASSERT_TRUE(img.ok());
        double s = 0;
        for (std::size_t k = 0; k < img.value().plane_size(); ++k) s += img.value().plane(0)[k];
        s /= static_cast<double>(img.value().plane_size());
        const auto& tex = mix->level(side == 0 ? 0 : 4);
        // One 256 x 256 window: its mean's standard error is at most std / sqrt(256 x 256 / r^2).
        EXPECT_NEAR(s, tex.texton().mean[0], 5 * field_std(tex, 0) * 16 / 256) << side;
    }
}

} // namespace
} // namespace textond::test
