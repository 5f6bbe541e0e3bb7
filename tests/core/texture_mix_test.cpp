// Texture mixing's models (texton-noise section 7): the optimal-transport barycentre of two
// Gaussian models and its textons.
#include "core/texture_mix.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

namespace textond::test {
namespace {

// For grey textures tau_rho^ = ((1 - rho)|t_u^| + rho |t_v^|) e^{i arg t_v^}: the modulus is the
// linear interpolation of the moduli, at every frequency.
TEST(TextureMix, GreyBarycentreModulusIsTheInterpolatedModulus) {
    auto pair = core::common_models(load_exemplar("skimage_gravel.png"),
                                    load_exemplar("skimage_grass.png"), true, 2, 0);
    ASSERT_TRUE(pair.ok());
    ASSERT_EQ(pair.value().u.channels, 1);
    const auto& u = pair.value().u.t_hat[0];
    const auto& v = pair.value().v.t_hat[0];
    for (double rho : {0.0, 0.3, 0.5, 0.85, 1.0}) {
        const core::GaussianModel m = core::barycentre_model(pair.value(), rho, 2);
        double worst = 0, scale = 0;
        for (int i = 0; i < u.height(); ++i)
            for (int j = 0; j < u.cwidth(); ++j) {
                const double want = (1 - rho) * std::abs(u.row(i)[j]) + rho * std::abs(v.row(i)[j]);
                worst = std::max(worst, std::fabs(std::abs(m.t_hat[0].row(i)[j]) - want));
                scale = std::max(scale, want);
            }
        EXPECT_LT(worst, 1e-6 * scale) << "rho " << rho;
    }
}

// rho = 0 keeps u's colour covariance and mean (only the phases move); rho = 1 is v's model.
TEST(TextureMix, EndsAreTheTwoModels) {
    auto pair = core::common_models(load_exemplar("etr_sand01.png"),
                                    load_exemplar("etr_pebbles04.png"), true, 2, 0);
    ASSERT_TRUE(pair.ok());
    const core::GaussianModel m0 = core::barycentre_model(pair.value(), 0.0, 2);
    const core::GaussianModel m1 = core::barycentre_model(pair.value(), 1.0, 2);
    for (int c = 0; c < 3; ++c) {
        const auto ci = static_cast<std::size_t>(c);
        EXPECT_DOUBLE_EQ(m0.mean[ci], pair.value().u.mean[ci]);
        EXPECT_DOUBLE_EQ(m1.mean[ci], pair.value().v.mean[ci]);
        for (int d = 0; d < 3; ++d) {
            const double su = pair.value().u.covariance(c, c), sv = pair.value().v.covariance(c, c);
            EXPECT_NEAR(m0.covariance(c, d), pair.value().u.covariance(c, d), 1e-5 * su);
            EXPECT_NEAR(m1.covariance(c, d), pair.value().v.covariance(c, d), 1e-5 * sv);
        }
    }
    // Halfway, the mean is halfway.
    const core::GaussianModel mh = core::barycentre_model(pair.value(), 0.5, 2);
    EXPECT_NEAR(mh.mean[1], 0.5 * (pair.value().u.mean[1] + pair.value().v.mean[1]), 1e-12);
}

// The barycentre interpolates the phase-aligned spectra linearly (texture mixing, section 3:
// t_rho = (1 - rho) phi t_u + rho t_v), so the total variance is a quadratic in rho,
// (1 - rho)^2 A + rho^2 B + 2 rho (1 - rho) C, whose cross term C = sum |<t_u, t_v>| / N lies in
// [0, sqrt(A B)] (Cauchy-Schwarz). Three values fix the quadratic; two more must lie on it.
// Between the two variances it need not lie: disjoint spectra give (A + B) / 4 halfway.
TEST(TextureMix, TotalVarianceIsTheQuadraticOfLinearSpectra) {
    auto pair = core::common_models(load_exemplar("etr_sand01.png"),
                                    load_exemplar("etr_pebbles04.png"), true, 2, 0);
    ASSERT_TRUE(pair.ok());
    auto total = [&](double rho) {
        const core::GaussianModel m = core::barycentre_model(pair.value(), rho, 2);
        return m.covariance(0, 0) + m.covariance(1, 1) + m.covariance(2, 2);
    };
    const double a = total(0.0), b = total(1.0), half = total(0.5);
    const double cross = 2.0 * half - 0.5 * (a + b);
    EXPECT_GE(cross, 0.0);
    EXPECT_LE(cross, std::sqrt(a * b) * (1 + 1e-4));
    for (double rho : {0.25, 0.8}) {
        const double quadratic =
            (1 - rho) * (1 - rho) * a + rho * rho * b + 2 * rho * (1 - rho) * cross;
        // Spectra are stored as float: relative error ~1e-6 a coefficient, 1e-4 is 100x that.
        EXPECT_NEAR(total(rho), quadratic, 1e-4 * (a + b)) << rho;
    }
}

// Grey and colour exemplars of different sizes meet on one grid: centre crop, grey promoted.
TEST(TextureMix, CommonModelsCropAndPromote) {
    auto pair = core::common_models(load_exemplar("skimage_gravel.png"),
                                    load_exemplar("etr_sand01.png"), true, 2, 0);
    ASSERT_TRUE(pair.ok());
    EXPECT_EQ(pair.value().u.width, 256);
    EXPECT_EQ(pair.value().u.height, 256);
    EXPECT_EQ(pair.value().u.channels, 3);
    EXPECT_EQ(pair.value().v.channels, 3);
    // The promoted grey model has three equal channels.
    EXPECT_DOUBLE_EQ(pair.value().u.covariance(0, 0), pair.value().u.covariance(2, 2));
}

// Every level is analysed from the same white-noise start; ends carry the ends' means; the levels
// are finite and their RME is that of an ordinary texton.
TEST(TextureMix, LevelsShareTheStartAndEndAtTheModels) {
    auto pair = core::common_models(load_exemplar("etr_sand01.png"),
                                    load_exemplar("etr_pebbles04.png"), true, 2, 0);
    ASSERT_TRUE(pair.ok());
    core::AnalysisParams p;
    p.size = 32;
    p.iterations = 20;
    int calls = 0;
    auto mix = core::mix_levels(pair.value(), p, 5, [&](int done, int total) {
        ++calls;
        EXPECT_EQ(total, 5);
        EXPECT_EQ(done, calls);
    });
    ASSERT_TRUE(mix.ok());
    ASSERT_EQ(mix.value().levels.size(), 5u);
    EXPECT_EQ(calls, 5);
    EXPECT_DOUBLE_EQ(mix.value().levels.front().mean[0], pair.value().u.mean[0]);
    EXPECT_DOUBLE_EQ(mix.value().levels.back().mean[0], pair.value().v.mean[0]);
    for (double rme : mix.value().rme) EXPECT_TRUE(rme > 0 && rme < 1) << rme;
    // The same seed for every level: an ordinary analysis of v gives level R-1's coefficients
    // (to float rounding: its colour covariance comes back through an inverse FFT).
    auto alone = core::texton_from_model(pair.value().v, p);
    const auto& a = alone.texton.alpha.data;
    const auto& b = mix.value().levels.back().alpha.data;
    ASSERT_EQ(a.size(), b.size());
    double worst = 0, top = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        worst = std::max(worst, std::fabs(double(a[k]) - b[k]));
        top = std::max(top, std::fabs(double(a[k])));
    }
    EXPECT_LT(worst, 1e-5 * top);
    // ... and a different seed gives other coefficients: the start is what makes them equal.
    core::AnalysisParams other = p;
    other.seed = 1;
    EXPECT_NE(core::texton_from_model(pair.value().v, other).texton.alpha.data, a);
    EXPECT_FALSE(core::mix_levels(pair.value(), p, 1).ok());
    core::MixField bad;
    bad.dx = bad.dy = 0;
    EXPECT_TRUE(bad.validate().has_value());
    // The origin may lie anywhere on the plane, its edges included: |x|, |y| <= 2^62.
    core::MixField edge;
    edge.x0 = -std::ldexp(1.0, 62);
    edge.y0 = std::ldexp(1.0, 62);
    EXPECT_FALSE(edge.validate().has_value());
    edge.x0 = std::nextafter(edge.x0, -1e300);
    EXPECT_TRUE(edge.validate().has_value());
}

TEST(TextureMix, RampAndMaskFields) {
    core::MixField ramp;
    ramp.x0 = 100;
    ramp.dx = 0;
    ramp.dy = -2; // upwards, normalised on use
    ramp.y0 = 50;
    ramp.width = 10;
    EXPECT_DOUBLE_EQ(ramp.rho(0, 50), 0.0);
    EXPECT_DOUBLE_EQ(ramp.rho(0, 45), 0.5);
    EXPECT_DOUBLE_EQ(ramp.rho(0, -1e9), 1.0);
    EXPECT_EQ(core::mix_level(0.5, 21), 10);
    EXPECT_EQ(core::mix_level(0.024, 21), 0);
    EXPECT_EQ(core::mix_level(0.026, 21), 1);
    core::MixField mask;
    mask.kind = core::MixField::Kind::mask;
    mask.mask = core::Image(2, 1, 1);
    mask.mask.at(0, 1, 0) = 1.0f;
    mask.scale = 4; // pixel 0 covers texels [0, 4), pixel 1 [4, 8)
    EXPECT_DOUBLE_EQ(mask.rho(2, 2), 0.0);
    EXPECT_DOUBLE_EQ(mask.rho(4, 2), 0.5);
    EXPECT_DOUBLE_EQ(mask.rho(6, 2), 1.0);
    EXPECT_DOUBLE_EQ(mask.rho(1e6, -1e6), 1.0);
    EXPECT_FALSE(mask.validate().has_value());
}

// The common grid: each side the smaller of the two, at most the 1024 window an analysis takes
// (two 2048² exemplars had mixed on their whole grid at 2.8x the estimate), a side with a prime
// factor over 7 cut to a fast FFT size, never under 2r.
TEST(TextureMix, TheGridIsTheWindowAnAnalysisWouldTake) {
    EXPECT_EQ(core::mix_grid(2048, 1500, 4096, 1100, 64), (std::array<int, 2>{1024, 1024}));
    EXPECT_EQ(core::mix_grid(509, 700, 600, 800, 32), (std::array<int, 2>{504, 700}));
    EXPECT_EQ(core::mix_grid(256, 512, 512, 256, 64), (std::array<int, 2>{256, 256}));
    EXPECT_EQ(core::mix_grid(67, 67, 90, 90, 66), (std::array<int, 2>{67, 67})); // 64 < 2r
}

} // namespace
} // namespace textond::test
