#include "core/fft2d.h"
#include "core/periodic_component.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace textond;
using namespace textond::core;

namespace {
double mean_of(const Image& u, int c) {
    double s = 0;
    for (std::size_t k = 0; k < u.plane_size(); ++k) s += u.plane(c)[k];
    return s / static_cast<double>(u.plane_size());
}

// Share of the spectrum's energy (DC excluded) on the two axes xi1 = 0 or xi2 = 0.
double axis_energy_share(const Image& u) {
    Spectrum s(u.width, u.height);
    RealFft2d::get(u.width, u.height)->forward(u.plane(0), s, 1);
    double axis = 0, total = 0;
    for (int i = 0; i < u.height; ++i)
        for (int j = 0; j < u.width / 2 + 1; ++j) {
            if (i == 0 && j == 0) continue;
            const double e = s.column_weight(j) * std::norm(std::complex<double>(s.row(i)[j]));
            total += e;
            if (i == 0 || j == 0) axis += e;
        }
    return axis / total;
}
} // namespace

TEST(PeriodicComponent, PeriodicInputIsReturnedUnchanged) {
    // "Periodic" for the decomposition means no jump across the border: opposite edges agree, so
    // Lap_interior u = Lap u and p = u (RPN paper, section 5.2: "if h is constant at its boundary
    // we have p = h"). A DFT-periodic smooth image is not such an image: its border jump is an
    // ordinary neighbour difference, which the decomposition treats as a discontinuity.
    const int w = 64, h = 48;
    Image u(w, h, 1);
    const double two_pi = 6.283185307179586;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            u.at(0, x, y) = static_cast<float>(0.5 + 0.2 * std::cos(two_pi * 3 * x / (w - 1)) +
                                               0.1 * std::cos(two_pi * 2 * y / (h - 1)) *
                                                   std::sin(two_pi * x / (w - 1)));
    EXPECT_LT(test::max_abs_diff(periodic_component(u), u), 1e-5);
    // Idempotent on its own output's defining property: Lap p is what p's equation says.
    const Image p = periodic_component(test::white_noise(w, h, 1, 2));
    EXPECT_LT(test::max_abs_diff(periodic_laplacian(p),
                                 interior_laplacian(test::white_noise(w, h, 1, 2))),
              1e-3);
}

TEST(PeriodicComponent, KeepsTheMeanAndSolvesThePoissonEquation) {
    const Image u = test::crop(test::load_exemplar("etr_sand01.png"), 200, 120);
    const Image p = periodic_component(u, 2);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean_of(p, c), mean_of(u, c), 1e-5);
    // Lap p = Lap_interior u (RPN paper eq. (3)), to float precision.
    const Image lp = periodic_laplacian(p);
    const Image li = interior_laplacian(u);
    EXPECT_LT(test::max_abs_diff(lp, li), 2e-4);
    // And it is not the trivial answer: the image did change near its border.
    EXPECT_GT(test::max_abs_diff(p, u), 1e-2);
}

TEST(PeriodicComponent, RemovesTheAxisCrossOfANonPeriodicImage) {
    // Texture plus a lighting gradient: strongly non-periodic, so its DFT has a bright cross.
    const int w = 128, h = 128;
    Image u = test::white_noise(w, h, 1, 11);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            u.at(0, x, y) = 0.05f * u.at(0, x, y) + 0.004f * static_cast<float>(x) +
                            0.002f * static_cast<float>(y);
    const double before = axis_energy_share(u);
    const double after = axis_energy_share(periodic_component(u));
    // White noise alone puts (w + h - 2) / (w h) ~ 1.6% of its energy on the axes.
    EXPECT_GT(before, 0.5);
    EXPECT_LT(after, 0.05);
}
