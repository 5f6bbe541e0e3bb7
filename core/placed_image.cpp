#include "core/placed_image.h"

#include <algorithm>

namespace textond::core {

PlacedTap placed_tap(double origin, double scale, int size, double x) {
    // Pixel centres at origin + scale (i + 1/2): bilinear between them, edge-clamped.
    const double f = std::clamp((x - origin) / scale - 0.5, 0.0, size - 1.0);
    PlacedTap t;
    t.i = std::min(static_cast<int>(f), size - 2 < 0 ? 0 : size - 2);
    t.j = std::min(t.i + 1, size - 1);
    t.a = f - t.i;
    return t;
}

void sample_placed(const Image& image, double x0, double y0, double scale, double x, double y,
                   double* out) {
    const PlacedTap tx = placed_tap(x0, scale, image.width, x);
    const PlacedTap ty = placed_tap(y0, scale, image.height, y);
    for (int c = 0; c < image.channels; ++c) out[c] = sample_placed(image, c, tx, ty);
}

} // namespace textond::core
