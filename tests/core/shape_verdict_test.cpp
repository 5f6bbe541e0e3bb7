// The micro/macro verdict (core/shape_verdict.h): a Gaussian texture has no excess over its ADSN
// null, the verdict is the same on any thread count, the shared photos keep the kinds of
// ../shared/data/exemplars/README.md, and drawn shapes are macro; with the diagnosis of why the
// phase coherence index called a repeated motif micro (core/README.md "Micro or macro").
#include "core/phase_coherence.h"
#include "core/random.h"
#include "core/shape_verdict.h"
#include "core/spectral_synthesis.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

core::Image drawn(int n, float (*f)(int, int)) {
    core::Image u(n, n, 1);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) u.at(0, x, y) = f(x, y);
    return u;
}

// Discs of radius 8 on a square lattice of period 32 (a spotted print at 1024 x 1024).
float spots32(int x, int y) {
    const double dx = x % 32 - 16.0, dy = y % 32 - 16.0;
    return dx * dx + dy * dy < 64.0 ? 1.0f : 0.0f;
}

float spots64(int x, int y) {
    const double dx = x % 64 - 32.0, dy = y % 64 - 32.0;
    return dx * dx + dy * dy < 256.0 ? 1.0f : 0.0f;
}

// Bricks 64 x 32 with joints of 4 pixels, courses offset by half a brick.
float bricks(int x, int y) {
    const int shift = (y / 32) % 2 * 32;
    return (y % 32 < 4 || (x + shift) % 64 < 4) ? 0.0f : 1.0f;
}

// One synthesis of a photo's own model is a sample of the null: each statistic's excess lies
// within 5 of the null's standard deviations (estimated from its 8 syntheses) of 0, and the
// verdict is micro.
TEST(ShapeVerdict, AGaussianTextureHasNoExcessOverItsNull) {
    for (const char* name : {"skimage_brick.png", "etr_sand01.png", "etr_pave02.png"}) {
        const core::Image u = load_exemplar(name);
        for (auto method : {core::SpectralMethod::adsn, core::SpectralMethod::rpn}) {
            const core::ShapeVerdict v = core::shape_verdict(
                core::synthesize_from_exemplar(u, method, u.width, u.height, 5), 2);
            const double e[] = {v.excess.tensor, v.excess.tv, v.excess.lines, v.excess.specks};
            const double sd[] = {v.null_sd.tensor, v.null_sd.tv, v.null_sd.lines, v.null_sd.specks};
            for (int i = 0; i < 4; ++i) EXPECT_LT(std::fabs(e[i]), 5.0 * sd[i]) << name << " " << i;
            EXPECT_EQ(v.kind(), core::TextureKind::micro) << name << " " << v.score;
        }
    }
}

TEST(ShapeVerdict, SameOnAnyThreadCountAndSeeded) {
    const core::Image u = load_exemplar("etr_pebbles04.png");
    const core::ShapeVerdict one = core::shape_verdict(u, 1), two = core::shape_verdict(u, 2);
    EXPECT_EQ(one.score, two.score);
    EXPECT_NE(core::shape_verdict(u, 2, /*seed=*/1).score, two.score); // the null is drawn
    EXPECT_EQ(one.factor, 1);
    EXPECT_EQ(core::shape_verdict(load_exemplar("skimage_brick.png"), 2).factor, 2); // 512
}

// The nine shared photos keep their kinds (README: brick and pave are macro, the rest micro;
// measured scores: brick +15.2, pave +8.7; grass -0.27 is the closest to the band).
TEST(ShapeVerdict, TheSharedPhotosKeepTheirKinds) {
    for (const char* name :
         {"skimage_gravel.png", "etr_floor01.png", "etr_pebbles04.png", "skimage_grass.png",
          "etr_sand01.png", "mypaint_HR_Cork.png", "mypaint_HR_DecoPaper.png"})
        EXPECT_EQ(core::shape_verdict(load_exemplar(name), 2).kind(), core::TextureKind::micro)
            << name;
    for (const char* name : {"skimage_brick.png", "etr_pave02.png"})
        EXPECT_EQ(core::shape_verdict(load_exemplar(name), 2).kind(), core::TextureKind::macro)
            << name;
}

// The diagnosis: the phase coherence index box-reduces the exemplar to short sides of ~128, 64 and
// 32 pixels; a motif whose period the reduction divides becomes a flat image (no TV, coherence 0)
// or a pattern at the Nyquist frequency, whose gradients all have one size, so its TV is
// sqrt(pi / 2) times a Gaussian field's: coherence 1 - sqrt(pi / 2) = -0.253. The scales cancel
// and the spotted print is called micro. The shape verdict compares with the same reductions of
// the print's own Gaussian syntheses, which fold the same way.
TEST(ShapeVerdict, DiagnosisARepeatedMotifFoldsAwayInThePhaseCoherenceScales) {
    const core::Image print = drawn(1024, spots32);
    const core::PhaseCoherence pc = core::phase_coherence(print, 2);
    ASSERT_EQ(pc.scales.size(), 3u);
    EXPECT_GT(pc.scales[0].coherence, 0.25);                                    // 128 px: dots
    EXPECT_NEAR(pc.scales[1].coherence, 1.0 - std::sqrt(3.14159265 / 2), 0.02); // 64: Nyquist
    EXPECT_EQ(pc.scales[2].si.mean, 0.0);                                       // 32: flat
    EXPECT_EQ(pc.kind(), core::TextureKind::micro);
}

// Drawn shapes the phase coherence index called micro or macro by accident of the scales: bricks
// (index -0.016, micro) and a print of period 64 are macro; white noise is micro. A print of period
// 32 at 1024 pixels is still called micro (core/README.md: its dots are 4 pixels wide at the
// measured scale, where the statistics read them as specks).
TEST(ShapeVerdict, DrawnShapesAreMacroAndNoiseIsMicro) {
    EXPECT_EQ(core::phase_coherence(drawn(1024, bricks), 2).kind(), core::TextureKind::micro);
    EXPECT_EQ(core::shape_verdict(drawn(1024, bricks), 2).kind(), core::TextureKind::macro);
    EXPECT_EQ(core::shape_verdict(drawn(1024, spots64), 2).kind(), core::TextureKind::macro);
    core::Rng rng(9);
    core::Image noise(512, 512, 1);
    for (float& v : noise.data) v = static_cast<float>(rng.normal());
    EXPECT_EQ(core::shape_verdict(noise, 2).kind(), core::TextureKind::micro);
}

TEST(ShapeVerdict, FlatAndTinyImagesAreMicro) {
    EXPECT_EQ(core::shape_verdict(core::Image(64, 64, 3, 0.5f)).kind(), core::TextureKind::micro);
    const core::ShapeVerdict tiny = core::shape_verdict(core::Image(8, 8, 1, 0.2f));
    EXPECT_EQ(tiny.score, core::kShapeWeights.bias);
    EXPECT_EQ(tiny.kind(), core::TextureKind::micro);
}

} // namespace
} // namespace textond::test
