#pragma once
// The grid-based Poisson point process of texton noise (texton-noise paper, section 8), as fixed
// by render/NOISE_SPEC.md sections 1, 3 and 4: integer cells of side a ~ r/1.6, an exact Poisson
// count by integer comparison against a threshold table, points at integer + 24-bit fraction
// positions, random signs (section 7), optional periodic keys (tileable mode).
#include <array>
#include <cstdint>
#include <vector>

namespace textond::core::noise {

constexpr double kMinMni = 1.0;
constexpr double kMaxMni = 200.0;
constexpr int kMaxThresholds = 256;

// Cell side in texels for a texton of support r: round(r / 1.6), at least 1.
constexpr int cell_size(int r) {
    return (5 * r + 4) / 8 > 1 ? (5 * r + 4) / 8 : 1;
}

// e^-mu for 0 <= mu <= 100 with basic IEEE operations only, in a fixed order, so the threshold
// table is the same on every machine (std::exp is not guaranteed to be correctly rounded).
double exp_neg(double mu);

// T[j] = floor(F(j) 2^32) for the Poisson(mu) distribution function F, while below 2^32 - 1.
std::vector<std::uint32_t> poisson_thresholds(double mu);

// Poisson count for the draw d0: the number of thresholds <= d0.
inline int poisson_count(const std::uint32_t* t, int n, std::uint32_t d0) {
    int lo = 0, hi = n; // first index with t[i] > d0
    while (lo < hi) {
        const int mid = (lo + hi) / 2;
        if (t[mid] <= d0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

struct CellPoint {
    std::int64_t bx = 0, by = 0;  // integer texel part of the position
    std::uint32_t fx = 0, fy = 0; // 24-bit fraction: position = b + f / 2^24
    float eps = 1.0f;             // random sign
};

// Everything that defines the point process for one texton size and MNI.
struct GridPoisson {
    int r = 0;
    int a = 0; // cell side, texels
    double mni = 30.0;
    double lambda = 0.0; // points per texel
    double mu = 0.0;     // points per cell
    std::vector<std::uint32_t> thresholds;
    std::array<std::int64_t, 2> period{0, 0}; // tileable mode, in cells (0 = none)

    GridPoisson(int texton_size, double mni_, std::array<std::int64_t, 2> period_ = {0, 0});

    // Appends the points of cell (cx, cy) in draw order; returns how many.
    int cell_points(std::uint64_t seed, std::int64_t cx, std::int64_t cy,
                    std::vector<CellPoint>& out) const;
};

// floor(a / b) for b > 0.
constexpr std::int64_t floor_div(std::int64_t a, std::int64_t b) {
    const std::int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}
constexpr std::int64_t floor_mod(std::int64_t a, std::int64_t b) {
    return a - floor_div(a, b) * b;
}

} // namespace textond::core::noise
