#include "core/colour_matrix.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace textond::core;

namespace {
ColourMatrix make(std::initializer_list<double> v) {
    ColourMatrix m;
    m.n = 3;
    int k = 0;
    for (double x : v) {
        m(k / 3, k % 3) = x;
        ++k;
    }
    return m;
}
} // namespace

TEST(ColourMatrix, SqrtSquaresBack) {
    const ColourMatrix a = make({4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0});
    const ColourMatrix s = sqrt_psd(a);
    EXPECT_LT(max_abs_difference(multiply(s, s), a), 1e-12);
    EXPECT_LT(max_abs_difference(s, transpose(s)), 1e-12);
}

TEST(ColourMatrix, PseudoInverseSqrtOfRankOneIsFiniteAndConsistent) {
    // Grey stored as RGB: covariance v v^T with v = (1, 1, 1) * sigma. A plain inverse is singular.
    const ColourMatrix a = make({2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0});
    const ColourMatrix p = pinv_sqrt_psd(a);
    const ColourMatrix s = sqrt_psd(a);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) ASSERT_TRUE(std::isfinite(p(i, j)));
    // s p s = s (Moore-Penrose) and s p is the projector onto (1,1,1).
    EXPECT_LT(max_abs_difference(multiply(multiply(s, p), s), s), 1e-9);
    const ColourMatrix proj = multiply(s, p);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) EXPECT_NEAR(proj(i, j), 1.0 / 3.0, 1e-9);
}
