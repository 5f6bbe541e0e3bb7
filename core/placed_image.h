#pragma once
// An image laid on the plane: its pixel (i, j) covers texels origin + scale [i, i + 1) x
// [j, j + 1); read bilinearly between pixel centres and clamped at its edges, so it extends
// without end. What a mix's mask (texture_mix.h) and a splat's weights (splat_blend.h) are.
#include "core/image.h"

namespace textond::core {

// One axis of a lookup at texel coordinate x: pixels i and j (= i + 1, or i at an edge), and
// j's share a.
struct PlacedTap {
    int i = 0, j = 0;
    double a = 0;
};
PlacedTap placed_tap(double origin, double scale, int size, double x);

inline double sample_placed(const Image& image, int c, const PlacedTap& tx, const PlacedTap& ty) {
    auto m = [&](int i, int j) { return static_cast<double>(image.at(c, i, j)); };
    return (1 - ty.a) * ((1 - tx.a) * m(tx.i, ty.i) + tx.a * m(tx.j, ty.i)) +
           ty.a * ((1 - tx.a) * m(tx.i, ty.j) + tx.a * m(tx.j, ty.j));
}

// Every channel of `image` at texel (x, y), into out[0 .. channels).
void sample_placed(const Image& image, double x0, double y0, double scale, double x, double y,
                   double* out);

} // namespace textond::core
