#include "core/canonical_texton.h"

#include "core/bspline.h"

#include <cmath>

namespace textond::core {

Image canonical_texton(const GaussianModel& model, int order, int threads) {
    const int w = model.width, h = model.height, nc = model.channels, cw = w / 2 + 1;
    const auto fft = RealFft2d::get(w, h);
    const std::vector<float> sqrtb = sqrt_bhat_grid(order, w, h);
    const float luminance[3] = {1.0f / 3.0f, 1.0f / 2.0f, 1.0f / 6.0f};
    std::vector<Spectrum> spec = model.t_hat;
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < cw; ++j) {
            const float sb = sqrtb[static_cast<std::size_t>(i) * cw + j];
            if (nc == 1) {
                cfloat& v = spec[0].row(i)[j];
                v = cfloat(std::abs(v) / sb, 0.0f);
                continue;
            }
            cfloat lum;
            for (int c = 0; c < nc; ++c)
                lum += luminance[c] * spec[static_cast<std::size_t>(c)].row(i)[j];
            const float mag = std::abs(lum);
            const cfloat unphase = mag > 0.0f ? std::conj(lum) / mag : cfloat(1.0f, 0.0f);
            for (int c = 0; c < nc; ++c) {
                cfloat& v = spec[static_cast<std::size_t>(c)].row(i)[j];
                v = v * unphase / sb;
            }
        }
    Image out(w, h, nc);
    const float inv_n = 1.0f / (static_cast<float>(w) * static_cast<float>(h));
    for (int c = 0; c < nc; ++c) {
        fft->inverse(spec[static_cast<std::size_t>(c)], out.plane(c), threads);
        float* p = out.plane(c);
        for (std::size_t k = 0; k < out.plane_size(); ++k) p[k] *= inv_n;
    }
    return out;
}

Texton cropped_canonical_texton(const GaussianModel& model, int size, int order, int threads) {
    const Image full = canonical_texton(model, order, threads);
    Texton t;
    t.size = size;
    t.channels = model.channels;
    t.order = order;
    t.mean = model.mean;
    t.alpha = Image(size, size, model.channels);
    const int half = size / 2;
    for (int c = 0; c < model.channels; ++c)
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const int sx = ((x - half) % model.width + model.width) % model.width;
                const int sy = ((y - half) % model.height + model.height) % model.height;
                t.alpha.at(c, x, y) = full.at(c, sx, sy);
            }
    return t;
}

} // namespace textond::core
