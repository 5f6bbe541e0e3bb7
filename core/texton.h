#pragma once
#include "core/image.h"
#include "core/marginals.h"

#include <array>

namespace textond::core {

// Texton interpolation coefficients (texton-noise paper, section 4, eq. (3)):
// h(y) = sum_k alpha(k) psi_order(y - k), with alpha supported on [0, size)^2.
struct Texton {
    int size = 0;     // r
    int channels = 0; // 1 or 3
    int order = 1;    // 0 nearest (discrete SOT), 1 bilinear, 3 cubic B-spline
    std::array<double, 3> mean{};
    Image alpha; // size x size x channels
    // The exemplar's colour marginals, for restoring them on request (core/marginals.h); empty
    // for textons without an exemplar (mixes) or analysed before they were kept.
    MarginalModel marginals;
};

} // namespace textond::core
