// The micro/macro verdict (core/phase_coherence.h): the closed-form mean and standard deviation of
// the TV under random phase (Leclaire and Moisan, JMIV 2015, section 3.2) against Gaussian samples,
// and the documented threshold on the shared photos.
#include "core/phase_coherence.h"
#include "core/spectral_synthesis.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

using core::SpectralMethod;

// TV(u * W) over n ADSN samples of u (exactly the model the closed form is about: the ADSN of the
// exemplar's periodic component, one noise for all channels, so its grey level is the ADSN of
// u's grey level). Mean within 4 standard errors of the closed form; the sample deviation within
// 4 standard errors (1 / sqrt(2 (n - 1)) relative) of the closed form's.
void check_moments(const core::Image& u, const std::string& name, int n) {
    const core::SharpnessIndex si = core::sharpness_index(u);
    ASSERT_GT(si.sd, 0.0);
    double s = 0, s2 = 0;
    for (int seed = 1; seed <= n; ++seed) {
        const core::Image v =
            core::synthesize_from_exemplar(u, SpectralMethod::adsn, u.width, u.height, seed);
        // A sample is periodic already: its periodic component would smooth its true border.
        const double tv = core::sharpness_index(v, 1, /*periodic=*/true).tv;
        s += tv;
        s2 += tv * tv;
    }
    const double mean = s / n, sd = std::sqrt((s2 - n * mean * mean) / (n - 1));
    EXPECT_LT(std::fabs(mean - si.mean), 4.0 * si.sd / std::sqrt(double(n)))
        << name << ": sample mean " << mean << ", closed form " << si.mean << " +- " << si.sd;
    EXPECT_LT(std::fabs(sd / si.sd - 1.0), 4.0 / std::sqrt(2.0 * (n - 1)))
        << name << ": sample sd " << sd << ", closed form " << si.sd;
}

TEST(PhaseCoherence, ClosedFormMeanAndDeviationOfTheRandomPhaseTv) {
    // grey, 512, strong structure; colour, 256
    for (const char* name : {"skimage_brick.png", "etr_sand01.png"})
        check_moments(load_exemplar(name), name, 48);
    // Diagonal stripes g(x + y): dx u = dy u, so the x-y cross term is half the variance (without
    // it the deviation falls by 1 - 1/sqrt(2) = 0.29, far beyond 4 standard errors of 0.016 at
    // 2000 samples of 64 x 64).
    core::Image stripes(64, 64, 1);
    std::uint32_t h = 12345;
    std::vector<float> g(64);
    for (float& v : g) {
        h = h * 1664525u + 1013904223u;
        v = float(h >> 8) / float(1 << 24);
    }
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) stripes.at(0, x, y) = g[(x + y) % 64];
    check_moments(stripes, "diagonal stripes", 2000);
}

TEST(PhaseCoherence, AGaussianTextureIsMicro) {
    // The ADSN of a macro-texture has its spectrum and none of its phase coherence.
    const core::Image brick = load_exemplar("skimage_brick.png");
    for (std::uint64_t seed : {1, 2, 3}) {
        const auto p = core::phase_coherence(
            core::synthesize_from_exemplar(brick, SpectralMethod::adsn, 512, 512, seed));
        EXPECT_EQ(p.kind(), core::TextureKind::micro) << p.index;
        for (const auto& s : p.scales) // within 4 random-phase standard deviations of 0
            EXPECT_LT(std::fabs(s.si.deviation), 4.0) << s.width << " " << s.si.deviation;
    }
}

// The thresholds fitted on the corpus (tests/verdict/) also sort two shared photos of each kind,
// each at least 0.01 from them (measured: sand 0.026, gravel 0.018, brick 0.196, pave 0.089).
TEST(PhaseCoherence, ThresholdsSortTheSharedMicroAndMacroPhotos) {
    for (const char* name : {"etr_sand01.png", "skimage_gravel.png"}) {
        const auto p = core::phase_coherence(load_exemplar(name));
        EXPECT_EQ(p.kind(), core::TextureKind::micro) << name;
        EXPECT_LT(p.index, core::kMicroCoherence - 0.01) << name;
    }
    for (const char* name : {"skimage_brick.png", "etr_pave02.png"}) {
        const auto p = core::phase_coherence(load_exemplar(name));
        EXPECT_EQ(p.kind(), core::TextureKind::macro) << name;
        EXPECT_GT(p.index, core::kMacroCoherence + 0.01) << name;
    }
    EXPECT_EQ(core::texture_kind((core::kMicroCoherence + core::kMacroCoherence) / 2),
              core::TextureKind::borderline);
}

TEST(PhaseCoherence, FlatAndTinyImagesAreDefined) {
    const core::Image flat(64, 64, 3, 0.5f);
    const auto p = core::phase_coherence(flat);
    EXPECT_EQ(p.index, 0.0);
    EXPECT_EQ(p.full.index, 0.0);
    core::Image tiny(16, 20, 1);
    for (std::size_t i = 0; i < tiny.data.size(); ++i) tiny.data[i] = float(i % 7) / 7.0f;
    const auto t = core::phase_coherence(tiny);
    ASSERT_EQ(t.scales.size(), 1u); // below 32 pixels: the image itself
    EXPECT_TRUE(std::isfinite(t.index));
}

TEST(PhaseCoherence, NormalTailHasNoUnderflow) {
    EXPECT_NEAR(core::minus_log10_phi(0.0), std::log10(2.0), 1e-12);
    EXPECT_NEAR(core::minus_log10_phi(-2.0), -std::log10(0.022750131948179), 1e-9);
    // The series, from x = -30 down, agrees with erfc where both hold (erfc(30 / sqrt 2) is
    // 5e-198, still a normal double), and grows like x^2 / (2 ln 10) far out.
    EXPECT_NEAR(core::minus_log10_phi(-30.0), -std::log10(0.5 * std::erfc(30.0 / std::sqrt(2.0))),
                1e-6);
    EXPECT_NEAR(core::minus_log10_phi(-100.0), 2173.87, 0.01);
}

} // namespace
} // namespace textond::test
