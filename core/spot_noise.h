#pragma once
// Discrete spot noise on a finite window (SOT paper, Algorithm 1): Poisson points of intensity
// lambda = mni / r^2 on Omega - S, f(x) = m + (sum_i alpha(x - x_i) - lambda sum alpha) /
// sqrt(lambda). The texton's coefficients are used as a discrete kernel on Z^2 (exact for order 0).
// This is the reference for the continuous texton noise of render/.
#include "core/texton.h"

#include <cstdint>

namespace textond::core {

struct Window {
    std::int64_t x0 = 0;
    std::int64_t y0 = 0;
    int width = 0;
    int height = 0;
};

Image discrete_spot_noise(const Texton& texton, double mni, std::uint64_t seed, const Window& w);

} // namespace textond::core
