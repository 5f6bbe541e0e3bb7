// Material sets (core/material_set.h, render/normal_map.h): maps of one set keep the exemplar
// set's cross-covariance, and the normal map is the normalised analytic gradient of the height.
// The set is derived from a shared photo (pebble_set, render_fixtures.h).
#include "core/grid_poisson.h"
#include "core/material_set.h"
#include "core/noise_levels.h"
#include "core/texton_covariance.h"
#include "render/cpu_backend.h"
#include "render/normal_map.h"
#include "tests/render/render_fixtures.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

using core::noise::CellPoint;
using core::noise::floor_div;
using core::noise::GridPoisson;
using render::CpuBackend;
using render::NoiseRequest;
using render::PreparedTexton;

// Derivatives of the centred B-splines of orders 1 and 3 (closed forms, independent of the
// backend's weight formulas), and the splines themselves.
double spline(int order, double t) {
    t = std::fabs(t);
    if (order == 1) return t < 1.0 ? 1.0 - t : 0.0;
    if (t < 1.0) return 2.0 / 3.0 - t * t + t * t * t / 2.0;
    if (t < 2.0) return (2.0 - t) * (2.0 - t) * (2.0 - t) / 6.0;
    return 0.0;
}
double spline_slope(int order, double t) {
    const double s = t < 0 ? -1.0 : 1.0;
    t = std::fabs(t);
    if (order == 1) return t < 1.0 ? -s : 0.0;
    if (t < 1.0) return s * (-2.0 * t + 1.5 * t * t);
    if (t < 2.0) return s * (-0.5 * (2.0 - t) * (2.0 - t));
    return 0.0;
}

// The height's gradient at (ix + X, iy + Y) texels by direct summation over every point of
// f(X) = m + scale sum_j eps_j sum_k alpha(k) psi(X - x_j - k) (NOISE_SPEC.md section 5).
std::array<double, 2> direct_gradient(const PreparedTexton& h, const GridPoisson& grid,
                                      std::uint64_t seed, double X, double Y, std::int64_t ix,
                                      std::int64_t iy) {
    const int r = h.size(), a = grid.a, order = h.order();
    std::vector<CellPoint> pts;
    double gx = 0.0, gy = 0.0;
    for (std::int64_t cy = floor_div(iy - r - 3, a); cy <= floor_div(iy + 3, a); ++cy)
        for (std::int64_t cx = floor_div(ix - r - 3, a); cx <= floor_div(ix + 3, a); ++cx) {
            pts.clear();
            grid.cell_points(seed, cx, cy, pts);
            for (const CellPoint& p : pts) {
                const double dx = X - static_cast<double>(p.bx - ix) - p.fx / 16777216.0;
                const double dy = Y - static_cast<double>(p.by - iy) - p.fy / 16777216.0;
                double sx = 0.0, sy = 0.0;
                for (int ky = 0; ky < r; ++ky)
                    for (int kx = 0; kx < r; ++kx) {
                        const double al = h.texton().alpha.at(0, kx, ky);
                        sx += al * spline_slope(order, dx - kx) * spline(order, dy - ky);
                        sy += al * spline(order, dx - kx) * spline_slope(order, dy - ky);
                    }
                gx += p.eps * sx;
                gy += p.eps * sy;
            }
        }
    const double scale = 1.0 / std::sqrt(grid.lambda);
    return {gx * scale, gy * scale};
}

TEST(MaterialSet, NormalMapIsTheNormalisedAnalyticGradientOfTheHeight) {
    CpuBackend cpu(2, 16);
    for (int order : {1, 3}) {
        const auto set = pebble_set(16, order);
        const auto height = set->map("height").value();
        const double strength = 8.0;
        for (int level : {0, -2}) {
            NoiseRequest q;
            q.seed = 11;
            q.level = level;
            q.x0 = -9;
            q.y0 = 5;
            q.width = q.height = 16;
            auto n = render::render_normal_map(cpu, *height, q, strength);
            ASSERT_TRUE(n.ok()) << n.error().message;
            const GridPoisson grid(height->size(), q.mni);
            const int s = level < 0 ? 1 << -level : 1;
            double worst = 0.0, steepest = 0.0;
            for (int y = 0; y < q.height; y += 3)
                for (int x = 0; x < q.width; x += 3) {
                    const std::int64_t px = q.x0 + x, py = q.y0 + y;
                    const std::int64_t ax = floor_div(px, s), ay = floor_div(py, s);
                    const auto g =
                        direct_gradient(*height, grid, q.seed, static_cast<double>(px - ax * s) / s,
                                        static_cast<double>(py - ay * s) / s, ax, ay);
                    const double nx = -strength * g[0], ny = strength * g[1];
                    const double inv = 1.0 / std::sqrt(nx * nx + ny * ny + 1.0);
                    const double want[3] = {nx * inv, ny * inv, inv};
                    for (int c = 0; c < 3; ++c)
                        worst =
                            std::max(worst, std::fabs(2.0 * n.value().at(c, x, y) - 1.0 - want[c]));
                    steepest = std::max(steepest, std::hypot(nx, ny));
                }
            EXPECT_LT(worst, 1e-4) << "order " << order << " level " << level;
            EXPECT_GT(steepest, 0.1) << "the test's surface must not be flat";
        }
    }
}

// Normal tiles are windows onto one function: 2x2 tiles equal the region bit for bit, at a
// magnified, the exact, a box-filtered and a limit level.
TEST(MaterialSet, NormalTilesStitchBitExactly) {
    const auto set = pebble_set(16, 1);
    const auto height = set->map("height").value();
    CpuBackend cpu(2, 40);
    for (int level : {-1, 0, 2, height->limit_level() + 1}) {
        NoiseRequest q;
        q.seed = (std::uint64_t{1} << 40) + 3;
        q.level = level;
        q.x0 = -70;
        q.y0 = 33;
        q.width = q.height = 64;
        EXPECT_EQ(first_tile_off_the_region(
                      [&](const NoiseRequest& r) {
                          return render::render_normal_map(cpu, *height, r, 4.0);
                      },
                      q),
                  -1)
            << "level " << level;
    }
}

// The albedo and height maps, rendered separately with one seed, keep the set's covariance
// between them (R, G, B against height): at level 0, at a box-filtered level and at a limit
// level, where each map reads the set's normals. Each window's sample covariance is one draw;
// the mean over independent windows (far apart, new seeds) is compared with the model within
// 4 standard errors of that mean.
TEST(MaterialSet, MapsKeepTheSetsCrossCovariance) {
    const auto set = pebble_set(32, 1);
    const auto albedo = set->map("albedo").value();
    const auto height = set->map("height").value();
    ASSERT_TRUE(height->limit_coupled());
    CpuBackend cpu(2);
    const core::LagCovariance cov = core::sampled_covariance(set->texton());
    for (int level : {0, 2, set->limit_level()}) {
        const core::ColourMatrix model =
            core::box_average_covariance(cov, std::int64_t{1} << level, 0, 0);
        constexpr int kWindows = 24;
        std::vector<std::array<double, 3>> draws;
        for (int w = 0; w < kWindows; ++w) {
            NoiseRequest q;
            q.seed = 100 + static_cast<std::uint64_t>(w);
            q.level = level;
            q.x0 = static_cast<std::int64_t>(w) * 100000;
            q.y0 = -q.x0;
            q.width = q.height = 96;
            auto a = cpu.render(*albedo, q);
            auto h = cpu.render(*height, q);
            ASSERT_TRUE(a.ok() && h.ok());
            std::array<double, 3> d{};
            const double n = static_cast<double>(a.value().plane_size());
            const double hm = set->texton().mean[3];
            for (int c = 0; c < 3; ++c) {
                const double am = set->texton().mean[static_cast<std::size_t>(c)];
                double s = 0.0;
                for (std::size_t k = 0; k < a.value().plane_size(); ++k)
                    s += (a.value().plane(c)[k] - am) * (h.value().plane(0)[k] - hm);
                d[static_cast<std::size_t>(c)] = s / n;
            }
            draws.push_back(d);
        }
        for (int c = 0; c < 3; ++c) {
            double mean = 0.0, sq = 0.0;
            for (const auto& d : draws) mean += d[static_cast<std::size_t>(c)];
            mean /= kWindows;
            for (const auto& d : draws)
                sq += (d[static_cast<std::size_t>(c)] - mean) *
                      (d[static_cast<std::size_t>(c)] - mean);
            const double se = std::sqrt(sq / (kWindows - 1) / kWindows);
            const double want = model(c, 3);
            EXPECT_NEAR(mean, want, 4.0 * se) << "level " << level << " channel " << c;
            // The maps are strongly related (height is albedo's luminance): a process per map
            // would give 0.
            EXPECT_GT(want, 8.0 * se) << "level " << level << " channel " << c;
        }
    }
}

TEST(MaterialSet, MapsAreCheckedAndNamed) {
    const auto set = pebble_set(16, 1);
    EXPECT_EQ(set->map("albedo").value()->channels(), 3);
    EXPECT_EQ(set->map("height").value()->channels(), 1);
    EXPECT_EQ(set->map("roughness").error().code, ErrorCode::not_found);
    EXPECT_TRUE(core::validate_maps({{"albedo", 0, 3}, {"height", 3, 1}}, 4) == std::nullopt);
    EXPECT_TRUE(core::validate_maps({{"albedo", 0, 3}, {"height", 3, 1}}, 5).has_value());
    EXPECT_TRUE(core::validate_maps({{"height", 0, 3}}, 3).has_value());
    EXPECT_TRUE(core::validate_maps({{"bump", 0, 1}}, 1).has_value());
    EXPECT_TRUE(core::validate_maps({{"ao", 0, 1}, {"ao", 1, 1}}, 2).has_value());
    // Order 0 has no gradient.
    const auto nearest = pebble_set(16, 0);
    CpuBackend cpu(1);
    NoiseRequest q;
    q.width = q.height = 8;
    EXPECT_FALSE(render::render_normal_map(cpu, *nearest->map("height").value(), q, 1.0).ok());
}

// A set's views share its joint model without owning the set: dropping the set frees it while a
// view (a request in flight) still renders, limit levels included.
TEST(MaterialSet, ASetIsFreedWhileItsViewsLive) {
    auto set = pebble_set(16, 1);
    std::weak_ptr<const PreparedTexton> watch = set;
    auto height = set->map("height").value();
    set.reset();
    EXPECT_TRUE(watch.expired()) << "the set and its views must not own each other";
    CpuBackend cpu;
    NoiseRequest q;
    q.width = q.height = 8;
    for (int level : {0, height->limit_level()}) {
        q.level = level;
        EXPECT_TRUE(cpu.render(*height, q).ok()) << "level " << level;
    }
}

} // namespace
} // namespace textond::test
