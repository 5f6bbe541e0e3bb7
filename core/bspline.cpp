#include "core/bspline.h"

#include <cmath>
#include <stdexcept>

namespace textond::core {

bool valid_interpolation_order(int order) {
    return order == 0 || order == 1 || order == 3;
}

const std::vector<double>& bspline_autocorrelation_taps(int order) {
    // beta^{2n+1} sampled at the integers: beta^1 = delta; beta^3 = (1, 4, 1)/6;
    // beta^7 = (1, 120, 1191, 2416, 1191, 120, 1)/5040.
    static const std::vector<double> k0{1.0};
    static const std::vector<double> k1{1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0};
    static const std::vector<double> k3{1.0 / 5040,    120.0 / 5040, 1191.0 / 5040, 2416.0 / 5040,
                                        1191.0 / 5040, 120.0 / 5040, 1.0 / 5040};
    switch (order) {
    case 0:
        return k0;
    case 1:
        return k1;
    case 3:
        return k3;
    default:
        throw std::invalid_argument("interpolation order must be 0, 1 or 3");
    }
}

double bspline_autocorrelation_hat(int order, double omega) {
    const auto& taps = bspline_autocorrelation_taps(order);
    double s = taps[static_cast<std::size_t>(order)];
    for (int t = 1; t <= order; ++t)
        s += 2.0 * taps[static_cast<std::size_t>(order + t)] * std::cos(t * omega);
    return s;
}

std::vector<float> sqrt_bhat_grid(int order, int width, int height) {
    const double two_pi = 6.283185307179586476925286766559;
    const int cw = width / 2 + 1;
    std::vector<double> bx(static_cast<std::size_t>(cw)), by(static_cast<std::size_t>(height));
    for (int j = 0; j < cw; ++j)
        bx[static_cast<std::size_t>(j)] = bspline_autocorrelation_hat(order, two_pi * j / width);
    for (int i = 0; i < height; ++i)
        by[static_cast<std::size_t>(i)] = bspline_autocorrelation_hat(order, two_pi * i / height);
    std::vector<float> out(static_cast<std::size_t>(cw) * height);
    for (int i = 0; i < height; ++i)
        for (int j = 0; j < cw; ++j)
            out[static_cast<std::size_t>(i) * cw + j] = static_cast<float>(
                std::sqrt(bx[static_cast<std::size_t>(j)] * by[static_cast<std::size_t>(i)]));
    return out;
}

} // namespace textond::core
