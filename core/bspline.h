#pragma once
// The B-spline factor of an interpolated texton (texton-noise paper, section 4.1, eq. (4)).
// A texton h = sum_k alpha(k) psi(. - k) with psi the B-spline of degree n (the interpolation
// order: 0 nearest, 1 bilinear, 3 cubic) has sampled covariance alpha~*alpha*b, where b is psi*psi
// (the B-spline of degree 2n+1) sampled on Z^2. Order 1 gives the paper's [1/6 2/3 1/6]^2.
#include <vector>

namespace textond::core {

bool valid_interpolation_order(int order);

// Taps b(t) for t = -order..order in one dimension (b is separable: b(x, y) = b(x) b(y)).
const std::vector<double>& bspline_autocorrelation_taps(int order);

// One-dimensional DTFT of the taps at angular frequency omega: b0 + 2 sum_t b(t) cos(t omega).
// Strictly positive for the supported orders, so sqrt and division are safe.
double bspline_autocorrelation_hat(int order, double omega);

// sqrt(b^(xi)) on the half-spectrum grid of a width x height image (rows of width/2+1 values).
std::vector<float> sqrt_bhat_grid(int order, int width, int height);

} // namespace textond::core
