#include "core/periodic_resample.h"

#include "core/fft2d.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

namespace textond::core {

Image resample_periodic(const Image& in, int width, int height, int threads) {
    if (width < 1 || height < 1 || in.empty())
        throw std::invalid_argument("resample_periodic: empty image or size");
    if (width == in.width && height == in.height) return in;
    const int W = in.width, H = in.height;
    const auto fwd = RealFft2d::get(W, H);
    const auto inv = RealFft2d::get(width, height);
    Image out(width, height, in.channels);
    // A frequency is kept when it is strictly below both Nyquist limits of its axis; on an axis
    // whose size does not change, every frequency is kept.
    auto keep = [](int s, int a, int b) { return a == b || 2 * std::abs(s) < std::min(a, b); };
    const float scale = 1.0f / (static_cast<float>(W) * static_cast<float>(H));
    Spectrum src(W, H), dst(width, height);
    for (int c = 0; c < in.channels; ++c) {
        fwd->forward(in.plane(c), src, threads);
        for (int oy = 0; oy < height; ++oy) {
            cfloat* row = dst.row(oy);
            std::fill(row, row + dst.cwidth(), cfloat(0.0f, 0.0f));
            const int sy = oy <= height / 2 ? oy : oy - height;
            if (!keep(sy, H, height)) continue;
            const cfloat* from = src.row(sy >= 0 ? sy : sy + H);
            for (int ox = 0; ox < dst.cwidth(); ++ox)
                if (ox < src.cwidth() && keep(ox, W, width)) row[ox] = from[ox] * scale;
        }
        inv->inverse(dst, out.plane(c), threads);
    }
    return out;
}

} // namespace textond::core
