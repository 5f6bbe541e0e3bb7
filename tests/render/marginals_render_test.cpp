// Marginal restoration in the renders (marginals=exemplar): tiles still stitch and equal the
// region on every backend, OSMesa agrees with the CPU, zoomed-out levels keep level 0's mean, and
// the acceptance measures of marginal restoration on two photos.
#include "render/cpu_backend.h"
#include "render/gl/osmesa_backend.h"
#include "tests/render/marginal_fidelity.h"
#include "tests/render/render_fixtures.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

using render::Marginals;
using render::NoiseRequest;

std::shared_ptr<render::GlBackend> osmesa() {
    static auto b = render::make_osmesa_backend();
    return b.ok() ? b.value() : nullptr;
}

TEST(MarginalRestoration, TilesStitchAndEqualTheRegionOnEveryBackend) {
    const auto tex = analysed_texton("etr_pebbles04.png", 64);
    render::CpuBackend cpu;
    std::vector<render::Backend*> backends = {&cpu};
    if (auto gl = osmesa()) backends.push_back(gl.get());
    for (render::Backend* b : backends)
        for (int level : {0, 2, -1, tex->limit_level() + 1}) {
            NoiseRequest q;
            q.marginals = Marginals::exemplar;
            q.seed = (std::uint64_t{1} << 33) + 5;
            q.level = level;
            q.x0 = -300;
            q.y0 = 77;
            q.width = 96;
            q.height = 64;
            EXPECT_EQ(first_tile_off_the_region(
                          [&](const NoiseRequest& r) { return b->render(*tex, r); }, q),
                      -1)
                << b->name() << " level " << level;
        }
}

// The GL backend evaluates the noise in GLSL and applies the same tables to the floats it reads
// back: the noise differs from the CPU's by ~1e-6 of its std (gl_backend_test), and the tables'
// slope is at most a few times 1 (bounded here by 1e-4 of the std; 1e-3 for the limit model).
TEST(MarginalRestoration, OsmesaAgreesWithCpu) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    const auto tex = analysed_texton("skimage_brick.png", 64);
    render::CpuBackend cpu;
    for (int level : {0, 3, tex->limit_level()}) {
        NoiseRequest q;
        q.marginals = Marginals::exemplar;
        q.level = level;
        q.width = 80;
        q.height = 60;
        q.precision = render::Precision::u8; // restored from floats whatever the caller keeps
        auto a = cpu.render(*tex, q), b = gl->render(*tex, q);
        ASSERT_TRUE(a.ok() && b.ok());
        const double bound = (level >= tex->limit_level() ? 1e-3 : 1e-4) * field_std(*tex, 0);
        EXPECT_LE(max_abs_diff(a.value(), b.value()), bound) << "level " << level;
        q.marginals = Marginals::gaussian;
        auto g = cpu.render(*tex, q);
        EXPECT_GT(max_abs_diff(a.value(), g.value()), 0.01); // restoration did something
    }
}

// Brick is skewed (a long bright tail): the level-0 table at a zoomed-out level would move the
// mean by more than 1e-3 (core's Marginals test). Each level's own table keeps it: in expectation
// (quadrature over the level's Gaussian: measured 2.4e-5 at most, bounded by 1e-4) and in a 512 x
// 512 window at levels where pixels are nearly independent (within 1e-3 plus 4 standard errors; the
// limit model correlates 5 x 5 pixels, so the standard error is taken 5 times the independent one).
TEST(MarginalRestoration, ZoomedOutLevelsKeepTheMeanOfLevelZero) {
    const auto tex = analysed_texton("skimage_brick.png", 64);
    const double mean0 = tex->texton().mean[0] + tex->marginals(0)->expected(0);
    for (int level = 1; level <= 12; ++level) {
        const double e = tex->texton().mean[0] + tex->marginals(level)->expected(0);
        EXPECT_NEAR(e, mean0, 1e-4) << "level " << level;
    }
    render::CpuBackend cpu;
    for (int level : {tex->limit_level() + 2, 10, 16}) {
        NoiseRequest q;
        q.marginals = Marginals::exemplar;
        q.level = level;
        q.width = q.height = 512;
        auto img = cpu.render(*tex, q);
        ASSERT_TRUE(img.ok());
        const Moments m = moments(img.value().plane(0), img.value().plane_size());
        const double se = 5.0 * std::sqrt(m.variance / double(q.width * q.height));
        EXPECT_NEAR(m.mean, mean0, 1e-3 + 4.0 * se) << "level " << level;
    }
}

TEST(MarginalRestoration, MixesAndTextonsWithoutMarginalsRefuseIt) {
    auto base = analysed_texton("etr_sand01.png", 32);
    core::Texton bare = base->texton();
    bare.marginals = {};
    auto tex = render::PreparedTexton::make(bare);
    ASSERT_TRUE(tex.ok());
    NoiseRequest q;
    q.marginals = Marginals::exemplar;
    const auto e = tex.value()->check(q);
    ASSERT_TRUE(e.has_value());
    EXPECT_NE(e->message.find("marginals=gaussian"), std::string::npos);
    EXPECT_FALSE(base->check(q).has_value());
    core::MixField ramp;
    ramp.width = 512;
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 3, ramp);
    EXPECT_TRUE(mix->check(q).has_value());
}

// The acceptance bound on two photos (all nine: tests/bench/marginals_bench, README): W1 to the
// exemplar's marginal falls at least 3x, the noise's power-spectrum RME grows by at most 0.05.
TEST(MarginalRestoration, RestoresTheMarginalAndKeepsTheSpectrum) {
    for (const char* name : {"etr_sand01.png", "skimage_brick.png"}) {
        const MarginalFidelity f = marginal_fidelity(load_exemplar(name), 64, 3);
        EXPECT_GE(f.w1_gaussian / f.w1_exemplar, 3.0) << name;
        EXPECT_LE(f.rme_exemplar - f.rme_gaussian, 0.05) << name;
    }
}

} // namespace
} // namespace textond::test
