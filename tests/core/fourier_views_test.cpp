// Display spectra and periodic resampling: both defined by the DFT, so both are checked against
// functions whose DFT is known exactly (sums of cosines).
#include "core/periodic_resample.h"
#include "core/power_spectrum.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace textond::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

// u(x, y) = 0.5 + sum_k a_k cos(2 pi (fx_k x / w + fy_k y / h) + phase_k), on the grid of w x h
// samples; the same continuous periodic function whatever the grid size.
Image cosines(int w, int h, int channels) {
    Image u(w, h, channels);
    for (int c = 0; c < channels; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                u.at(c, x, y) = static_cast<float>(
                    0.5 + 0.2 * std::cos(2 * kPi * (3.0 * x / w + 1.0 * y / h) + 0.3 * c) +
                    0.1 * std::cos(2 * kPi * (-2.0 * x / w + 5.0 * y / h) + 1.1));
    return u;
}

TEST(PowerSpectrum, CosinesPeakWhereTheyShouldAndParsevalHolds) {
    const int w = 64, h = 48;
    const Image u = cosines(w, h, 3);
    const Image p = centred_power_spectrum(u);
    ASSERT_EQ(p.width, w);
    ASSERT_EQ(p.channels, 1);
    double total = 0, energy = 0;
    for (float v : p.data) total += v;
    for (int c = 0; c < 3; ++c) {
        double m = 0;
        for (std::size_t k = 0; k < u.plane_size(); ++k) m += u.plane(c)[k];
        m /= static_cast<double>(u.plane_size());
        for (std::size_t k = 0; k < u.plane_size(); ++k)
            energy += (u.plane(c)[k] - m) * (u.plane(c)[k] - m);
    }
    EXPECT_NEAR(total, energy / 3.0, 1e-3 * total); // Parseval, with our normalisation
    // A cosine of amplitude a puts (a/2)^2 |Omega| at +-f (centre at (w/2, h/2)).
    const double n = static_cast<double>(w) * h;
    EXPECT_NEAR(p.at(0, w / 2 + 3, h / 2 + 1), 0.01 * n, 1e-3 * n);
    EXPECT_NEAR(p.at(0, w / 2 - 3, h / 2 - 1), 0.01 * n, 1e-3 * n);
    EXPECT_NEAR(p.at(0, w / 2 - 2, h / 2 + 5), 0.0025 * n, 1e-3 * n);
    EXPECT_NEAR(p.at(0, w / 2, h / 2), 0.0, 1e-6 * n); // the mean is removed
    EXPECT_NEAR(p.at(0, w / 2 + 7, h / 2 + 7), 0.0, 1e-6 * n);
    // Display scale: the peak maps to 1, three decades below to 0.
    const Image d = log_display(p, log10_max(p), 3.0);
    EXPECT_FLOAT_EQ(d.at(0, w / 2 + 3, h / 2 + 1), 1.0f);
    EXPECT_FLOAT_EQ(d.at(0, w / 2, h / 2), 0.0f);
}

TEST(PeriodicResample, ReproducesTheSameTrigonometricPolynomialOnAnotherGrid) {
    const Image from = cosines(60, 40, 3);
    for (auto [w, h] : {std::pair{64, 45}, std::pair{51, 33}, std::pair{120, 80}}) {
        SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
        const Image got = resample_periodic(from, w, h);
        const Image want = cosines(w, h, 3);
        EXPECT_LT(test::max_abs_diff(got, want), 2e-5);
    }
    // Frequencies above the new Nyquist limit are dropped, not aliased.
    const Image small = resample_periodic(from, 8, 8); // keeps |f| < 4: drops (-2, 5)
    double worst = 0;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            const double want = 0.5 + 0.2 * std::cos(2 * kPi * (3.0 * x / 8 + 1.0 * y / 8));
            worst = std::max(worst, std::abs(small.at(0, x, y) - want));
        }
    EXPECT_LT(worst, 2e-5);
}

} // namespace
} // namespace textond::core
