#include "core/rme.h"

#include "core/bspline.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace textond::core {

double relative_model_error(const std::vector<Spectrum>& t_hat,
                            const std::vector<Spectrum>& k_hat) {
    if (t_hat.size() != k_hat.size() || t_hat.empty())
        throw std::invalid_argument("relative_model_error: channel mismatch");
    const int h = t_hat[0].height(), cw = t_hat[0].cwidth();
    const std::size_t nc = t_hat.size();
    double num = 0.0, den = 0.0;
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < cw; ++j) {
            const double w = t_hat[0].column_weight(j);
            double tt = 0.0, kk = 0.0;
            std::complex<double> cross(0.0, 0.0);
            for (std::size_t c = 0; c < nc; ++c) {
                const std::complex<double> t(t_hat[c].row(i)[j]);
                const std::complex<double> k(k_hat[c].row(i)[j]);
                tt += std::norm(t);
                kk += std::norm(k);
                cross += std::conj(t) * k;
            }
            num += w * (tt + kk - 2.0 * std::abs(cross));
            den += w * tt;
        }
    if (den <= 0.0) return num <= 0.0 ? 0.0 : INFINITY;
    return std::sqrt(std::max(0.0, num) / den);
}

double relative_model_error(const GaussianModel& model, const Image& kernel, int order, int dx,
                            int dy, int threads) {
    if (kernel.channels != model.channels || kernel.width > model.width ||
        kernel.height > model.height)
        throw std::invalid_argument("relative_model_error: kernel does not fit the model");
    const int w = model.width, h = model.height;
    const auto fft = RealFft2d::get(w, h);
    const std::vector<float> sqrtb = sqrt_bhat_grid(order, w, h);
    const int cw = w / 2 + 1;
    std::vector<float> placed(static_cast<std::size_t>(w) * h);
    std::vector<Spectrum> k_hat;
    for (int c = 0; c < model.channels; ++c) {
        std::fill(placed.begin(), placed.end(), 0.0f);
        for (int y = 0; y < kernel.height; ++y)
            for (int x = 0; x < kernel.width; ++x) {
                const int px = ((x + dx) % w + w) % w, py = ((y + dy) % h + h) % h;
                placed[static_cast<std::size_t>(py) * w + px] = kernel.at(c, x, y);
            }
        k_hat.emplace_back(w, h);
        fft->forward(placed.data(), k_hat.back(), threads);
        for (int i = 0; i < h; ++i)
            for (int j = 0; j < cw; ++j)
                k_hat.back().row(i)[j] *= sqrtb[static_cast<std::size_t>(i) * cw + j];
    }
    return relative_model_error(model.t_hat, k_hat);
}

ColourMatrix texton_noise_covariance(const Image& alpha, int order) {
    const auto& taps = bspline_autocorrelation_taps(order);
    ColourMatrix s;
    s.n = alpha.channels;
    const int w = alpha.width, h = alpha.height;
    for (int ty = -order; ty <= order; ++ty)
        for (int tx = -order; tx <= order; ++tx) {
            const double b = taps[static_cast<std::size_t>(ty + order)] *
                             taps[static_cast<std::size_t>(tx + order)];
            for (int c = 0; c < alpha.channels; ++c)
                for (int d = 0; d < alpha.channels; ++d) {
                    double acc = 0.0;
                    for (int y = std::max(0, -ty); y < std::min(h, h - ty); ++y)
                        for (int x = std::max(0, -tx); x < std::min(w, w - tx); ++x)
                            acc += static_cast<double>(alpha.at(c, x, y)) *
                                   alpha.at(d, x + tx, y + ty);
                    s(c, d) += b * acc;
                }
        }
    return s;
}

} // namespace textond::core
