#include "core/fft2d.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>

using namespace textond;
using namespace textond::core;

TEST(RealFft2d, MatchesDirectDftOnASmallOddImage) {
    const int w = 9, h = 6;
    const Image u = test::white_noise(w, h, 1, 3);
    Spectrum s(w, h);
    RealFft2d::get(w, h)->forward(u.plane(0), s, 1);
    const double two_pi = 6.283185307179586;
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < w / 2 + 1; ++j) {
            std::complex<double> acc;
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    acc += static_cast<double>(u.at(0, x, y)) *
                           std::exp(std::complex<double>(
                               0, -two_pi * (double(j) * x / w + double(i) * y / h)));
            EXPECT_NEAR(s.row(i)[j].real(), acc.real(), 1e-4);
            EXPECT_NEAR(s.row(i)[j].imag(), acc.imag(), 1e-4);
        }
}

TEST(RealFft2d, InverseOfForwardIsIdentityTimesN) {
    const int w = 70, h = 33;
    const Image u = test::white_noise(w, h, 1, 4);
    Spectrum s(w, h);
    const auto fft = RealFft2d::get(w, h);
    fft->forward(u.plane(0), s, 2);
    Image back(w, h, 1);
    fft->inverse(s, back.plane(0), 2);
    for (auto& v : back.data) v /= static_cast<float>(w * h);
    EXPECT_LT(test::max_abs_diff(u, back), 1e-5);
}

TEST(RealFft2d, PrunedForwardEqualsZeroPaddedFullForward) {
    const int w = 64, h = 48, r = 13;
    const Image block = test::white_noise(r, r, 1, 5);
    Image padded(w, h, 1);
    for (int y = 0; y < r; ++y)
        for (int x = 0; x < r; ++x) padded.at(0, x, y) = block.at(0, x, y);
    const auto fft = RealFft2d::get(w, h);
    Spectrum a(w, h), b(w, h);
    fft->forward(block.plane(0), r, r, r, a, 1);
    fft->forward(padded.plane(0), b, 1);
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < w / 2 + 1; ++j) EXPECT_EQ(a.row(i)[j], b.row(i)[j]);
}

TEST(RealFft2d, BitIdenticalForAnyThreadCount) {
    const int w = 200, h = 150;
    const Image u = test::white_noise(w, h, 1, 6);
    const auto fft = RealFft2d::get(w, h);
    Spectrum s1(w, h), s3(w, h);
    fft->forward(u.plane(0), s1, 1);
    fft->forward(u.plane(0), s3, 3);
    Image b1(w, h, 1), b3(w, h, 1);
    fft->inverse(s1, b1.plane(0), 1);
    fft->inverse(s3, b3.plane(0), 3);
    EXPECT_EQ(b1.data, b3.data);
}

// The plan cache keeps the sizes used last, not every size ever asked for; a size evicted while
// held stays usable, and one planned again gives the same bits.
TEST(RealFft2d, PlanCacheIsBoundedAndEvictedSizesStillTransform) {
    const int w = 37, h = 29;
    const Image u = test::white_noise(w, h, 1, 8);
    const auto held = RealFft2d::get(w, h);
    Spectrum before(w, h);
    held->forward(u.plane(0), before, 1);
    for (int k = 0; k < 3 * static_cast<int>(RealFft2d::kCachedSizes); ++k)
        RealFft2d::get(16 + k, 17);
    EXPECT_EQ(RealFft2d::cached_sizes(), RealFft2d::kCachedSizes);
    Spectrum again(w, h), replanned(w, h);
    held->forward(u.plane(0), again, 1);
    RealFft2d::get(w, h)->forward(u.plane(0), replanned, 1);
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < w / 2 + 1; ++j) {
            EXPECT_EQ(again.row(i)[j], before.row(i)[j]);
            EXPECT_EQ(replanned.row(i)[j], before.row(i)[j]);
        }
}
