#include "core/canonical_texton.h"
#include "core/periodic_component.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace textond;
using namespace textond::core;

TEST(CanonicalTexton, GreyIsSymmetricPeakedAtTheOriginWithTheModelsModulus) {
    const GaussianModel m = estimate_gaussian_model(
        periodic_component(test::crop(test::load_exemplar("skimage_gravel.png"), 128, 96)));
    const Image t = canonical_texton(m, 0);
    float peak = 0;
    for (float v : t.data) peak = std::max(peak, std::abs(v));
    EXPECT_FLOAT_EQ(std::abs(t.at(0, 0, 0)), peak); // ICASSP 2012, section 2.2
    for (int y = 0; y < t.height; ++y)
        for (int x = 0; x < t.width; ++x)
            EXPECT_NEAR(t.at(0, x, y), t.at(0, (t.width - x) % t.width, (t.height - y) % t.height),
                        1e-6);
    const GaussianModel mt = estimate_gaussian_model(t);
    for (int i = 0; i < t.height; ++i)
        for (int j = 0; j < t.width / 2 + 1; ++j)
            EXPECT_NEAR(std::abs(mt.t_hat[0].row(i)[j]) * std::sqrt(double(t.width * t.height)),
                        std::abs(m.t_hat[0].row(i)[j]), 1e-4);
}

TEST(CanonicalTexton, ColourKeepsThePhaseDifferencesBetweenChannels) {
    const GaussianModel m = estimate_gaussian_model(
        periodic_component(test::crop(test::load_exemplar("etr_sand01.png"), 96, 96)));
    const Image t = canonical_texton(m, 0);
    Spectrum s0(96, 96), s1(96, 96);
    const auto fft = RealFft2d::get(96, 96);
    fft->forward(t.plane(0), s0, 1);
    fft->forward(t.plane(1), s1, 1);
    int checked = 0;
    for (int i = 1; i < 96; i += 7)
        for (int j = 1; j < 49; j += 5) {
            const auto a = s0.row(i)[j] * std::conj(s1.row(i)[j]);
            const auto b = m.t_hat[0].row(i)[j] * std::conj(m.t_hat[1].row(i)[j]);
            if (std::abs(b) < 1e-3) continue;
            EXPECT_NEAR(std::arg(a * std::conj(b)), 0.0, 1e-2);
            ++checked;
        }
    EXPECT_GT(checked, 50);
}
