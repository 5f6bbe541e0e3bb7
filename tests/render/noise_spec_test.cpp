// The C++ noise against render/noise_vectors.json, produced by the independent Python reference
// render/tools/noise_reference.py from NOISE_SPEC.md alone.
#include "core/grid_poisson.h"
#include "core/noise_hash.h"
#include "core/noise_levels.h"
#include "render/cpu_backend.h"
#include "tests/render/noise_vectors.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

namespace nz = core::noise;

TEST(NoiseSpec, Mix32) {
    for (const auto& v : noise_vectors()["mix32"])
        EXPECT_EQ(nz::mix32(v[0].get<std::uint32_t>()), v[1].get<std::uint32_t>());
}

TEST(NoiseSpec, CellAndPixelKeys) {
    for (const auto& v : noise_vectors()["cell_key"])
        EXPECT_EQ(nz::cell_key(v[0].get<std::uint64_t>(), v[1].get<std::int64_t>(),
                               v[2].get<std::int64_t>()),
                  v[3].get<std::uint32_t>())
            << v.dump();
    for (const auto& v : noise_vectors()["pixel_key"])
        EXPECT_EQ(nz::pixel_key(v[0].get<std::uint64_t>(), v[1].get<int>(),
                                v[2].get<std::int64_t>(), v[3].get<std::int64_t>()),
                  v[4].get<std::uint32_t>())
            << v.dump();
}

TEST(NoiseSpec, SeedChangesEveryCellAndNoPeriod) {
    // The authors' defects: seed s + 1024 was the noise of s shifted, and cells repeated every
    // 1024. Here keys of (s, c) and (s + 1024, c - 1024) or (s, c + 1024) agree only by chance.
    int same_shift = 0, same_period = 0;
    for (int c = 0; c < 4096; ++c) {
        same_shift += nz::cell_key(7, c, 3) == nz::cell_key(7 + 1024, c - 1024, 3);
        same_period += nz::cell_key(7, c, 3) == nz::cell_key(7, c + 1024, 3);
    }
    EXPECT_EQ(same_shift, 0);
    EXPECT_EQ(same_period, 0);
}

TEST(NoiseSpec, Stream) {
    for (const auto& v : noise_vectors()["stream"]) {
        nz::Stream32 s(v[0].get<std::uint32_t>());
        for (const auto& d : v[1]) EXPECT_EQ(s.next(), d.get<std::uint32_t>());
    }
}

TEST(NoiseSpec, ExpNegIsBitExact) {
    for (const auto& v : noise_vectors()["exp_neg"]) {
        EXPECT_EQ(nz::exp_neg(v[0].get<double>()), v[1].get<double>());
        EXPECT_NEAR(nz::exp_neg(v[0].get<double>()), std::exp(-v[0].get<double>()),
                    1e-12 * std::exp(-v[0].get<double>()));
    }
}

TEST(NoiseSpec, CellSizeAndThresholds) {
    for (const auto& v : noise_vectors()["cell_size"])
        EXPECT_EQ(nz::cell_size(v[0].get<int>()), v[1].get<int>());
    for (const auto& v : noise_vectors()["thresholds"]) {
        const nz::GridPoisson g(v["r"].get<int>(), v["mni"].get<double>());
        EXPECT_EQ(g.mu, v["mu"].get<double>());
        EXPECT_EQ(g.thresholds, v["table"].get<std::vector<std::uint32_t>>());
    }
}

TEST(NoiseSpec, CellPoints) {
    for (const auto& v : noise_vectors()["cell_points"]) {
        std::array<std::int64_t, 2> period{0, 0};
        if (!v["period"].is_null()) period = v["period"].get<std::array<std::int64_t, 2>>();
        const nz::GridPoisson g(v["r"].get<int>(), v["mni"].get<double>(), period);
        std::vector<nz::CellPoint> pts;
        g.cell_points(v["seed"].get<std::uint64_t>(), v["cx"].get<std::int64_t>(),
                      v["cy"].get<std::int64_t>(), pts);
        ASSERT_EQ(pts.size(), v["points"].size()) << v.dump();
        for (std::size_t i = 0; i < pts.size(); ++i) {
            const auto& e = v["points"][i];
            EXPECT_EQ(pts[i].bx, e[0].get<std::int64_t>());
            EXPECT_EQ(pts[i].fx, e[1].get<std::uint32_t>());
            EXPECT_EQ(pts[i].by, e[2].get<std::int64_t>());
            EXPECT_EQ(pts[i].fy, e[3].get<std::uint32_t>());
            EXPECT_EQ(pts[i].eps, e[4].get<float>());
        }
    }
}

TEST(NoiseSpec, PixelNormals) {
    for (const auto& v : noise_vectors()["normals"]) {
        float z[3];
        nz::pixel_normals(v[0].get<std::uint64_t>(), v[1].get<int>(), v[2].get<std::int64_t>(),
                          v[3].get<std::int64_t>(), 3, z);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(z[c], v[4][c].get<double>(), 1e-5) << v.dump();
    }
}

TEST(NoiseSpec, FieldValuesOnCpu) {
    render::CpuBackend cpu(1);
    check_field_vectors(cpu);
}

} // namespace
} // namespace textond::test
