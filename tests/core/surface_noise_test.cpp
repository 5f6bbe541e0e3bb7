// Surface noise (texton-noise section 6): Proposition 3's mean, variance and MNI on a sphere, and
// the local frame.
#include "core/rme.h"
#include "core/surface_noise.h"
#include "core/texton_analysis.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace textond::test {
namespace {

constexpr double kSigmas = 4.5;
constexpr double kPi = 3.14159265358979323846;

TEST(SurfaceNoise, FrameIsOrthonormalAndContinuous) {
    for (int i = 0; i < 200; ++i) {
        // Fibonacci directions over the whole sphere, the south pole's neighbourhood included.
        const double z = 1 - 2 * (i + 0.5) / 200, rad = std::sqrt(1 - z * z);
        const double phi = i * kPi * (3 - std::sqrt(5.0));
        const core::Vec3 n = {rad * std::cos(phi), rad * std::sin(phi), z};
        core::Vec3 u1, u2;
        core::tangent_frame(n, u1, u2);
        auto dot = [](const core::Vec3& a, const core::Vec3& b) {
            return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        };
        EXPECT_NEAR(dot(u1, u1), 1, 1e-12);
        EXPECT_NEAR(dot(u2, u2), 1, 1e-12);
        EXPECT_NEAR(dot(u1, u2), 0, 1e-12);
        EXPECT_NEAR(dot(u1, n), 0, 1e-12);
        EXPECT_NEAR(dot(u2, n), 0, 1e-12);
        if (z < -0.99) continue; // the one singular direction
        // A small turn of the normal turns the frame by a comparably small amount.
        const double e = 1e-6;
        core::Vec3 m = {n[0] + e * u1[0], n[1] + e * u1[1], n[2] + e * u1[2]};
        const double len = std::sqrt(dot(m, m));
        for (double& c : m) c /= len;
        core::Vec3 v1, v2;
        core::tangent_frame(m, v1, v2);
        const double moved =
            std::sqrt((v1[0] - u1[0]) * (v1[0] - u1[0]) + (v1[1] - u1[1]) * (v1[1] - u1[1]) +
                      (v1[2] - u1[2]) * (v1[2] - u1[2]));
        EXPECT_LT(moved, 1e-6 * 2 / (1 + z) + 1e-9) << "z " << z;
    }
}

// Proposition 3 with random signs: mean m, variance integral h^2 = C(0) (the 2D noise's, once
// divided by sqrt(lambda r / 3)), and lambda r^3 = MNI points in the r-cube around each point.
// Points on a sphere of radius 20000 texels, ~1800 texels apart: independent samples.
TEST(SurfaceNoise, MeanVarianceAndMniOnASphereMatchProposition3) {
    for (int order : {1, 3}) {
        core::AnalysisParams p;
        p.size = 32;
        p.iterations = 30;
        p.order = order;
        auto analysed = core::analyze_texton(load_exemplar("etr_sand01.png"), p);
        ASSERT_TRUE(analysed.ok());
        const core::Texton& t = analysed.value().texton;
        const core::ColourMatrix c0 = core::texton_noise_covariance(t.alpha, t.order);
        const core::SurfaceNoise noise(t);
        const int n = 1600;
        std::vector<double> value[3], square[3], impacts;
        const core::Vec3 centre = {1.0e6, -3.0e5, 7.0e4};
        for (int i = 0; i < n; ++i) {
            const double z = 1 - 2 * (i + 0.5) / n, rad = std::sqrt(1 - z * z);
            const double phi = i * kPi * (3 - std::sqrt(5.0));
            const core::Vec3 dir = {rad * std::cos(phi), rad * std::sin(phi), z};
            const core::Vec3 y = {centre[0] + 20000 * dir[0], centre[1] + 20000 * dir[1],
                                  centre[2] + 20000 * dir[2]};
            float out[3];
            core::SurfaceStats stats;
            noise.eval(11, y, dir, out, &stats);
            impacts.push_back(static_cast<double>(stats.impacts));
            for (int c = 0; c < 3; ++c) {
                const double d = out[c] - t.mean[static_cast<std::size_t>(c)];
                value[c].push_back(out[c]);
                square[c].push_back(d * d);
            }
        }
        for (int c = 0; c < 3; ++c) {
            const Estimate m = estimate_of(value[c]), v = estimate_of(square[c]);
            EXPECT_NEAR(m.mean, t.mean[static_cast<std::size_t>(c)], kSigmas * m.se)
                << "order " << order << " channel " << c;
            EXPECT_NEAR(v.mean, c0(c, c), kSigmas * v.se) << "order " << order << " channel " << c;
        }
        const Estimate k = estimate_of(impacts);
        EXPECT_NEAR(k.mean, core::kDefaultSurfaceMni, kSigmas * k.se) << "order " << order;
    }
}

// The same point, seed and texton give the same colour; another seed or point another one; the
// value does not depend on how far from the origin the surface is beyond float rounding.
TEST(SurfaceNoise, DeterministicAndSeeded) {
    core::AnalysisParams p;
    p.size = 16;
    p.iterations = 10;
    auto analysed = core::analyze_texton(load_exemplar("etr_sand01.png"), p);
    ASSERT_TRUE(analysed.ok());
    const core::SurfaceNoise noise(analysed.value().texton);
    const core::Vec3 y = {10.25, -3.5, 7.75}, n = {0.0, 0.6, 0.8};
    float a[3], b[3], c[3], d[3];
    noise.eval(5, y, n, a);
    noise.eval(5, y, n, b);
    noise.eval(6, y, n, c);
    noise.eval(5, {10.25, -3.5, 8.75}, n, d);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a[k], b[k]);
    EXPECT_NE(a[0], c[0]);
    EXPECT_NE(a[0], d[0]);
}

// The height's gradient (Relief on meshes) against central differences of the noise itself along
// the tangent frame, at 300 points with tilted normals: order 3 (smooth: every point within
// 0.5% of the gradient's rms; float outputs over a 0.01-texel step leave ~1e-4) and order 1
// (piecewise linear: 95% of the points; ~60 points reach each one, so a step of 1e-4 texel
// straddles one of their kinks about 1% of the time). The
// gradient lies in the tangent plane. A sign or axis swap in the derivative fails all of it.
TEST(SurfaceNoise, GradientIsTheDerivativeAlongTheTangentPlane) {
    for (int order : {1, 3}) {
        core::AnalysisParams p;
        p.size = 16;
        p.iterations = 10;
        p.order = order;
        auto analysed = core::analyze_texton(load_exemplar("etr_sand01.png"), p);
        ASSERT_TRUE(analysed.ok());
        const core::SurfaceNoise noise(analysed.value().texton);
        const double step = order == 3 ? 1e-2 : 1e-4;
        const int n = 300;
        std::vector<double> err;
        double sq = 0;
        for (int i = 0; i < n; ++i) {
            const double z = 1 - 2 * (i + 0.5) / n, rad = std::sqrt(1 - z * z);
            const double phi = i * kPi * (3 - std::sqrt(5.0));
            const core::Vec3 nrm = {rad * std::cos(phi), rad * std::sin(phi), z};
            const core::Vec3 y = {37.3 * i, -11.7 * i, 5.1 * i + 0.37};
            const core::Vec3 g = noise.gradient(9, y, nrm);
            EXPECT_NEAR(g[0] * nrm[0] + g[1] * nrm[1] + g[2] * nrm[2], 0.0, 1e-9);
            core::Vec3 u[2];
            core::tangent_frame(nrm, u[0], u[1]);
            for (const core::Vec3& d : u) {
                float a[3], b[3];
                noise.eval(9, {y[0] + step * d[0], y[1] + step * d[1], y[2] + step * d[2]}, nrm, a);
                noise.eval(9, {y[0] - step * d[0], y[1] - step * d[1], y[2] - step * d[2]}, nrm, b);
                const double fd = (double(a[0]) - double(b[0])) / (2 * step);
                const double an = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
                err.push_back(std::fabs(fd - an));
                sq += an * an;
            }
        }
        const double rms = std::sqrt(sq / double(err.size()));
        ASSERT_GT(rms, 1e-3) << "a flat field checks nothing";
        std::sort(err.begin(), err.end());
        const double tol = (order == 3 ? 5e-3 : 1e-2) * rms;
        const std::size_t k = order == 3 ? err.size() - 1 : err.size() * 95 / 100;
        EXPECT_LE(err[k], tol) << "order " << order << ", rms " << rms;
    }
}

} // namespace
} // namespace textond::test
