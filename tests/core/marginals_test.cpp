// Marginal restoration's tables (core/marginals.h; Heitz and Neyret, HPG 2018): the PCA basis, the
// level-0 table mapping a Gaussian onto the exemplar's marginal, and the zoomed-out tables keeping
// the level-0 mean where the level-0 table would not.
#include "core/marginals.h"
#include "core/random.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace textond::test {
namespace {

// W1 between two samples through 1000 quantiles.
double w1(std::vector<double> a, std::vector<double> b) {
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    double s = 0;
    for (int j = 0; j < 1000; ++j) {
        const double p = (j + 0.5) / 1000;
        s += std::fabs(a[std::size_t(p * static_cast<double>(a.size()))] -
                       b[std::size_t(p * static_cast<double>(b.size()))]);
    }
    return s / 1000;
}

std::vector<double> along(const core::Image& u, const core::MarginalModel& m, int i) {
    std::vector<double> y(u.plane_size());
    for (std::size_t k = 0; k < y.size(); ++k)
        for (int c = 0; c < m.channels; ++c)
            y[k] += m.basis(c, i) * (u.plane(c)[k] - m.mean[std::size_t(c)]);
    return y;
}

TEST(Marginals, BasisIsOrthonormalAndDecorrelatesTheColours) {
    const core::Image u = load_exemplar("etr_pebbles04.png");
    const core::MarginalModel m = core::marginal_model(u);
    ASSERT_EQ(m.channels, 3);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double dot = 0;
            for (int c = 0; c < 3; ++c) dot += m.basis(c, i) * m.basis(c, j);
            EXPECT_NEAR(dot, i == j ? 1.0 : 0.0, 1e-9);
        }
    const auto y0 = along(u, m, 0), y1 = along(u, m, 1);
    double cross = 0, v0 = 0;
    for (std::size_t k = 0; k < y0.size(); ++k) {
        cross += y0[k] * y1[k];
        v0 += y0[k] * y0[k];
    }
    EXPECT_NEAR(cross / double(y0.size()), 0.0, 1e-6); // uncorrelated components
    EXPECT_NEAR(v0 / double(y0.size()), m.variance[0], 1e-6 + 1e-4 * m.variance[0]);
    for (int i = 0; i < 3; ++i)
        EXPECT_TRUE(
            std::is_sorted(m.quantiles[std::size_t(i)].begin(), m.quantiles[std::size_t(i)].end()));
}

// A skewed grey exemplar (brick: a long bright tail). Gaussian samples of the level-0 variance
// through the table have the exemplar's marginal: W1 to it within the 256 quantiles' resolution
// and the samples' own noise, where the Gaussian itself is 20x further.
TEST(Marginals, LevelZeroTableMapsAGaussianOntoTheExemplar) {
    const core::Image u = load_exemplar("skimage_brick.png");
    const core::MarginalModel m = core::marginal_model(u);
    const core::MarginalTables t(m, m.variance);
    core::Rng rng(7);
    std::vector<double> gauss(200000), mapped(gauss.size());
    const double sigma = std::sqrt(m.variance[0]);
    for (std::size_t k = 0; k < gauss.size(); ++k) {
        gauss[k] = sigma * rng.normal();
        float v = static_cast<float>(m.mean[0] + gauss[k]);
        t.apply(&v);
        mapped[k] = v - m.mean[0];
    }
    const auto y = along(u, m, 0);
    const double before = w1(y, gauss), after = w1(y, mapped);
    EXPECT_LT(after, 0.002) << before;
    EXPECT_GT(before, 20 * after);
}

// E[T_k(Y_k)] = E[T_0(Y_0)] at every zoomed-out variance (quadrature, so this is the table's own
// error: measured 3e-5 at most, bounded by 1e-4), while the level-0 table at a smaller variance
// moves the mean by more than 1e-3 on this skewed exemplar: what the per-level tables are for.
TEST(Marginals, ZoomedOutTablesKeepTheLevelZeroMean) {
    const core::MarginalModel m = core::marginal_model(load_exemplar("skimage_brick.png"));
    const core::MarginalTables t0(m, m.variance);
    const double e0 = t0.expected(0);
    for (double shrink : {0.5, 0.1, 0.01, 1e-4}) {
        const core::MarginalTables tk(m, {m.variance[0] * shrink, 0, 0});
        EXPECT_NEAR(tk.expected(0), e0, 1e-4) << shrink;
    }
    // The level-0 table fed the variance of a zoomed-out level (1% of level 0's).
    const double sk = std::sqrt(m.variance[0] * 0.01);
    double naive = 0;
    core::Rng rng(3);
    for (int k = 0; k < 100000; ++k) {
        float v = static_cast<float>(m.mean[0] + sk * rng.normal());
        t0.apply(&v);
        naive += (v - m.mean[0]) / 100000.0;
    }
    EXPECT_GT(std::fabs(naive - e0), 1e-3) << naive << " " << e0;
}

TEST(Marginals, ConstantComponentsPassThrough) {
    // Grey stored as RGB: two components have no variance and must stay as they are.
    core::Image u(64, 64, 3);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x)
            for (int c = 0; c < 3; ++c) u.at(c, x, y) = float((x * 7 + y * 13) % 64) / 64.0f;
    const core::MarginalModel m = core::marginal_model(u);
    const core::MarginalTables t(m, m.variance);
    float v[3] = {0.3f, 0.3f, 0.3f};
    t.apply(v);
    EXPECT_NEAR(v[0], v[1], 1e-6);
    EXPECT_NEAR(v[1], v[2], 1e-6);
    for (float x : v) EXPECT_TRUE(std::isfinite(x));
}

} // namespace
} // namespace textond::test
