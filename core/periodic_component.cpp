#include "core/periodic_component.h"

#include "core/fft2d.h"

#include <cmath>
#include <vector>

namespace textond::core {

namespace {
template <bool kPeriodic> Image laplacian(const Image& u) {
    Image out(u.width, u.height, u.channels);
    const int w = u.width, h = u.height;
    for (int c = 0; c < u.channels; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const double v = u.at(c, x, y);
                double acc = 0.0;
                const int nx[4] = {x - 1, x + 1, x, x};
                const int ny[4] = {y, y, y - 1, y + 1};
                for (int k = 0; k < 4; ++k) {
                    int xx = nx[k], yy = ny[k];
                    if (xx < 0 || xx >= w || yy < 0 || yy >= h) {
                        if (!kPeriodic) continue;
                        xx = (xx + w) % w;
                        yy = (yy + h) % h;
                    }
                    acc += v - u.at(c, xx, yy);
                }
                out.at(c, x, y) = static_cast<float>(acc);
            }
    return out;
}
} // namespace

Image periodic_laplacian(const Image& u) {
    return laplacian<true>(u);
}
Image interior_laplacian(const Image& u) {
    return laplacian<false>(u);
}

Image periodic_component(const Image& u, int threads) {
    const int w = u.width, h = u.height;
    Image p(w, h, u.channels);
    if (u.empty()) return p;
    const auto fft = RealFft2d::get(w, h);
    const Image lap = interior_laplacian(u);
    const double two_pi = 6.283185307179586476925286766559;
    const int cw = w / 2 + 1;
    std::vector<double> cx(static_cast<std::size_t>(cw)), cy(static_cast<std::size_t>(h));
    for (int j = 0; j < cw; ++j) cx[static_cast<std::size_t>(j)] = 2.0 * std::cos(two_pi * j / w);
    for (int i = 0; i < h; ++i) cy[static_cast<std::size_t>(i)] = 2.0 * std::cos(two_pi * i / h);
    const double inv_n = 1.0 / (static_cast<double>(w) * h);

    Spectrum spec(w, h);
    for (int c = 0; c < u.channels; ++c) {
        double sum = 0.0;
        const float* up = u.plane(c);
        for (std::size_t k = 0; k < u.plane_size(); ++k) sum += up[k];
        fft->forward(lap.plane(c), spec, threads);
        for (int i = 0; i < h; ++i) {
            cfloat* row = spec.row(i);
            for (int j = 0; j < cw; ++j) {
                const double denom =
                    4.0 - cx[static_cast<std::size_t>(j)] - cy[static_cast<std::size_t>(i)];
                row[j] = (i == 0 && j == 0)
                             ? cfloat(static_cast<float>(sum * inv_n), 0.0f)
                             : cfloat(static_cast<float>(row[j].real() * inv_n / denom),
                                      static_cast<float>(row[j].imag() * inv_n / denom));
            }
        }
        fft->inverse(spec, p.plane(c), threads);
    }
    return p;
}

} // namespace textond::core
