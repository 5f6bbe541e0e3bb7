#include "core/spectral_filter.h"

#include <cmath>

namespace textond::core {

double angular_frequency(int k, int n) {
    constexpr double kPi = 3.14159265358979323846;
    return 2.0 * kPi * (k <= n / 2 ? k : k - n) / static_cast<double>(n);
}

double gaussian_response(double wx, double wy, double sigma) {
    return std::exp(-0.5 * sigma * sigma * (wx * wx + wy * wy));
}

std::vector<float> filtered(const Spectrum& spec, const RealFft2d& fft, int threads,
                            const Transfer& t) {
    const int w = spec.width(), hgt = spec.height(), cw = spec.cwidth();
    Spectrum out(w, hgt);
    for (int i = 0; i < hgt; ++i)
        for (int j = 0; j < cw; ++j)
            out.row(i)[j] = spec.row(i)[j] * t[static_cast<std::size_t>(i) * cw + j];
    std::vector<float> v(static_cast<std::size_t>(w) * hgt);
    fft.inverse(out, v.data(), threads);
    const float inv = 1.0f / static_cast<float>(v.size());
    for (float& x : v) x *= inv;
    return v;
}

std::vector<float> filtered(const std::vector<float>& field, const RealFft2d& fft, int threads,
                            const Transfer& t) {
    Spectrum s(fft.width(), fft.height());
    fft.forward(field.data(), s, threads);
    return filtered(s, fft, threads, t);
}

double structure_tensor_anisotropy(const std::vector<float>& gx, const std::vector<float>& gy,
                                   const RealFft2d& fft, int threads, const Transfer& window) {
    std::vector<float> xx(gx.size()), yy(gx.size()), xy(gx.size());
    for (std::size_t i = 0; i < gx.size(); ++i) {
        xx[i] = gx[i] * gx[i];
        yy[i] = gy[i] * gy[i];
        xy[i] = gx[i] * gy[i];
    }
    const auto jxx = filtered(xx, fft, threads, window), jyy = filtered(yy, fft, threads, window),
               jxy = filtered(xy, fft, threads, window);
    double anisotropy = 0, trace = 0;
    for (std::size_t i = 0; i < jxx.size(); ++i) {
        const double d = jxx[i] - jyy[i];
        anisotropy += std::sqrt(d * d + 4.0 * double(jxy[i]) * jxy[i]);
        trace += double(jxx[i]) + jyy[i];
    }
    return trace > 0 ? anisotropy / trace : 0.0;
}

BandMoments band_moments(const std::vector<float>& field) {
    double m1 = 0;
    for (float v : field) m1 += v;
    m1 /= static_cast<double>(field.size());
    double m2 = 0, m3 = 0, m4 = 0;
    for (float v : field) {
        const double d = v - m1, s = d * d;
        m2 += s;
        m3 += s * d;
        m4 += s * s;
    }
    const double n = static_cast<double>(field.size());
    m2 /= n;
    m3 /= n;
    m4 /= n;
    if (m2 <= 0) return {};
    return {m3 / std::pow(m2, 1.5), std::log(m4 / (m2 * m2) / 3.0)};
}

} // namespace textond::core
