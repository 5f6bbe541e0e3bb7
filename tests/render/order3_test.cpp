// Cubic B-spline textons (texton-noise section 10, "higher order interpolation"), end to end on
// the CPU: the backend's tables and tap rules against a direct evaluation of
// f(X) = m + scale sum_j eps_j sum_k alpha(k) beta3(X - x_j - k) in double precision.
#include "core/grid_poisson.h"
#include "render/cpu_backend.h"
#include "tests/render/render_fixtures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace textond::test {
namespace {

using core::noise::CellPoint;
using core::noise::floor_div;
using core::noise::GridPoisson;
using render::CpuBackend;
using render::NoiseRequest;

// The centred cubic B-spline (closed form, independent of the backend's weight formulas).
double beta3(double t) {
    t = std::fabs(t);
    if (t < 1.0) return 2.0 / 3.0 - t * t + t * t * t / 2.0;
    if (t < 2.0) return (2.0 - t) * (2.0 - t) * (2.0 - t) / 6.0;
    return 0.0;
}

// f at the continuous point (X, Y) texels, channel c, summing every point that can reach it.
double direct_field(const render::PreparedTexton& tex, const GridPoisson& grid, std::uint64_t seed,
                    double X, double Y, std::int64_t ix, std::int64_t iy, int c) {
    // (ix, iy) is an integer anchor near (X, Y); X, Y are small offsets from it so that the
    // double arithmetic stays exact far from the origin.
    const int r = tex.size(), a = grid.a;
    std::vector<CellPoint> pts;
    double s = 0.0;
    for (std::int64_t cy = floor_div(iy - r - 3, a); cy <= floor_div(iy + 3, a); ++cy)
        for (std::int64_t cx = floor_div(ix - r - 3, a); cx <= floor_div(ix + 3, a); ++cx) {
            pts.clear();
            grid.cell_points(seed, cx, cy, pts);
            for (const CellPoint& p : pts) {
                const double dx = X - static_cast<double>(p.bx - ix) - p.fx / 16777216.0;
                const double dy = Y - static_cast<double>(p.by - iy) - p.fy / 16777216.0;
                double h = 0.0;
                for (int ky = 0; ky < r; ++ky) {
                    const double by = beta3(dy - ky);
                    if (by == 0.0) continue;
                    for (int kx = 0; kx < r; ++kx)
                        h += tex.texton().alpha.at(c, kx, ky) * beta3(dx - kx) * by;
                }
                s += p.eps * h;
            }
        }
    return tex.texton().mean[static_cast<std::size_t>(c)] + s / std::sqrt(grid.lambda);
}

// Levels 0 and -2 (4 pixels per texel), near the origin and 2^40 texels out.
TEST(Order3, BackendEqualsTheDirectCubicSum) {
    const auto tex = analysed_texton("etr_sand01.png", 16, 3);
    ASSERT_EQ(tex->order(), 3);
    CpuBackend cpu(2, 16);
    const std::int64_t far = std::int64_t{1} << 40;
    for (int level : {0, -2})
        for (std::int64_t origin : {std::int64_t{-7}, far}) {
            NoiseRequest q;
            q.seed = 5;
            q.level = level;
            q.x0 = origin;
            q.y0 = -origin;
            q.width = q.height = 20;
            auto out = cpu.render(*tex, q);
            ASSERT_TRUE(out.ok()) << out.error().message;
            const GridPoisson grid(tex->size(), q.mni);
            const int s = level < 0 ? 1 << -level : 1;
            double worst = 0.0;
            for (int c = 0; c < 3; ++c)
                for (int y = 0; y < q.height; y += 3)
                    for (int x = 0; x < q.width; x += 3) {
                        // Pixel P is the point P / s texels: anchor floor(P / s), offset.
                        const std::int64_t px = q.x0 + x, py = q.y0 + y;
                        const std::int64_t ax = floor_div(px, s), ay = floor_div(py, s);
                        const double X = static_cast<double>(px - ax * s) / s;
                        const double Y = static_cast<double>(py - ay * s) / s;
                        const double want = direct_field(*tex, grid, q.seed, X, Y, ax, ay, c);
                        worst = std::max(worst, std::fabs(want - out.value().at(c, x, y)));
                    }
            EXPECT_LT(worst, 2e-5 * field_std(*tex, 0))
                << "level " << level << " origin " << origin;
        }
}

// One function, many windows: 2x2 tiles equal the region bit for bit, at a magnified, the exact
// and a box-filtered level.
TEST(Order3, TilesStitchBitExactly) {
    const auto tex = analysed_texton("etr_sand01.png", 32, 3);
    CpuBackend cpu(2, 40);
    for (int level : {-1, 0, 2}) {
        NoiseRequest q;
        q.seed = 9;
        q.level = level;
        q.x0 = -70;
        q.y0 = 33;
        q.width = q.height = 128;
        EXPECT_EQ(first_tile_off_the_region(
                      [&](const NoiseRequest& r) { return cpu.render(*tex, r); }, q),
                  -1)
            << "level " << level;
    }
}

// Box-filtered levels hold for any B-spline order: level k is the 2^k box average of level 0.
TEST(Order3, BoxFilteredLevelsEqualTheBoxAverage) {
    const auto tex = analysed_texton("etr_sand01.png", 32, 3);
    CpuBackend cpu;
    for (int level : {1, 3}) {
        const int st = 1 << level, w = 24;
        NoiseRequest fine;
        fine.seed = 4;
        fine.x0 = 5 * st;
        fine.y0 = -3 * st;
        fine.width = fine.height = w * st;
        NoiseRequest coarse = fine;
        coarse.level = level;
        coarse.x0 = 5;
        coarse.y0 = -3;
        coarse.width = coarse.height = w;
        auto f = cpu.render(*tex, fine);
        auto g = cpu.render(*tex, coarse);
        ASSERT_TRUE(f.ok() && g.ok());
        double worst = 0;
        for (int y = 0; y < w; ++y)
            for (int x = 0; x < w; ++x) {
                double s = 0;
                for (int dy = 0; dy < st; ++dy)
                    for (int dx = 0; dx < st; ++dx) s += f.value().at(1, x * st + dx, y * st + dy);
                worst = std::max(worst, std::fabs(s / (st * st) - g.value().at(1, x, y)));
            }
        EXPECT_LT(worst, 1e-4 * field_std(*tex, 1)) << "level " << level;
    }
}

} // namespace
} // namespace textond::test
