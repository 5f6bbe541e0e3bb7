#include "core/gaussian_model.h"

#include <cmath>

namespace textond::core {

double plane_dot(const float* a, const float* b, std::size_t n) {
    double s = 0.0;
    for (std::size_t k = 0; k < n; ++k) s += static_cast<double>(a[k]) * b[k];
    return s;
}

GaussianModel estimate_gaussian_model(const Image& u, int threads) {
    GaussianModel m;
    m.width = u.width;
    m.height = u.height;
    m.channels = u.channels;
    m.t_u = Image(u.width, u.height, u.channels);
    const std::size_t n = u.plane_size();
    const double scale = 1.0 / std::sqrt(static_cast<double>(n));
    const auto fft = RealFft2d::get(u.width, u.height);
    for (int c = 0; c < u.channels; ++c) {
        const float* up = u.plane(c);
        double sum = 0.0;
        for (std::size_t k = 0; k < n; ++k) sum += up[k];
        const double mean = sum / static_cast<double>(n);
        m.mean[static_cast<std::size_t>(c)] = mean;
        float* tp = m.t_u.plane(c);
        for (std::size_t k = 0; k < n; ++k) tp[k] = static_cast<float>((up[k] - mean) * scale);
        m.t_hat.emplace_back(u.width, u.height);
        fft->forward(tp, m.t_hat.back(), threads);
    }
    m.covariance.n = u.channels;
    for (int c = 0; c < u.channels; ++c)
        for (int d = 0; d <= c; ++d)
            m.covariance(c, d) = m.covariance(d, c) = plane_dot(m.t_u.plane(c), m.t_u.plane(d), n);
    return m;
}

} // namespace textond::core
