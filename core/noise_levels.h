#pragma once
// Levels of texton noise (render/NOISE_SPEC.md, section 6): exact box filtering through
// pre-filtered coefficient tables, and the limiting Gaussian model once the texton spans fewer
// than two output pixels. Improves on the paper's MIP-mapped texton (texton-noise section 5),
// which only approximates the box average.
#include "core/colour_matrix.h"
#include "core/image.h"
#include "core/texton_covariance.h"

#include <array>
#include <cstdint>

namespace textond::core::noise {

constexpr int kMinLevel = -4;
constexpr int kMaxLevel = 24;

// K(r) = min { k >= 1 : 2^(k+1) > r }: the first level evaluated by the limit model.
int limit_level(int r);

// g(j) = mean of alpha over [j, j + st)^2 for j in [-(st - 1), r)^2, stored at j + st - 1 (so
// (r + st - 1)^2 per channel). Double sums, rounded once.
Image box_filtered_coefficients(const Image& alpha, int st);

struct LimitModel {
    ColourMatrix a; // symmetric square root of C_k(0)
    // Output channel c is row first + c of `a` applied to a.n normals: a material set's map
    // (channels [first, ...) of the set) draws the set's normals, so maps keep their
    // cross-covariance at limit levels too. 0 for a texton of its own.
    int first = 0;
    std::array<double, 25> kappa{}; // kappa(D) for D in [-2, 2]^2, row-major, sum kappa^2 = 1
};

// The limit model at st = 2^k texels per pixel (NOISE_SPEC.md section 6).
LimitModel limit_model(const LagCovariance& cov, std::int64_t st);

// z(Q): `channels` standard normals for output pixel (px, py) at `level` (Box-Muller).
void pixel_normals(std::uint64_t seed, int level, std::int64_t px, std::int64_t py, int channels,
                   float* out);

} // namespace textond::core::noise
