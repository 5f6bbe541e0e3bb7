#include "core/power_spectrum.h"

#include "core/fft2d.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace textond::core {

Image centred_power_spectrum(const Image& u, int threads) {
    if (u.empty()) throw std::invalid_argument("centred_power_spectrum: empty image");
    const int w = u.width, h = u.height;
    const auto fft = RealFft2d::get(w, h);
    Image out(w, h, 1);
    Spectrum s(w, h);
    std::vector<float> centred(u.plane_size());
    const double norm = 1.0 / (static_cast<double>(u.channels) * static_cast<double>(w) * h);
    for (int c = 0; c < u.channels; ++c) {
        const float* p = u.plane(c);
        double mean = 0;
        for (std::size_t k = 0; k < u.plane_size(); ++k) mean += p[k];
        mean /= static_cast<double>(u.plane_size());
        for (std::size_t k = 0; k < u.plane_size(); ++k)
            centred[k] = static_cast<float>(p[k] - mean);
        fft->forward(centred.data(), s, threads);
        // The half spectrum holds columns 0..w/2; the others are conjugates of (-x, -y).
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const bool direct = x <= w / 2;
                const int sx = direct ? x : w - x;
                const int sy = direct ? y : (h - y) % h;
                const double power = std::norm(std::complex<double>(s.row(sy)[sx]));
                const int ox = (x + w / 2) % w, oy = (y + h / 2) % h;
                out.at(0, ox, oy) += static_cast<float>(power * norm);
            }
    }
    return out;
}

double log10_max(const Image& p) {
    float m = 0;
    for (float v : p.data) m = std::max(m, v);
    return std::log10(std::max(m, 1e-30f));
}

Image log_display(const Image& p, double top, double decades) {
    Image out(p.width, p.height, 1);
    for (std::size_t k = 0; k < p.data.size(); ++k) {
        const double l = std::log10(std::max(static_cast<double>(p.data[k]), 1e-30));
        out.data[k] = static_cast<float>(std::clamp((l - (top - decades)) / decades, 0.0, 1.0));
    }
    return out;
}

} // namespace textond::core
