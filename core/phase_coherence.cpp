#include "core/phase_coherence.h"

#include "core/fft2d.h"
#include "core/periodic_component.h"
#include "core/working_window.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace textond::core {

namespace {

constexpr double kPi = 3.14159265358979323846;

// w(t) = E|X||Y| - E|X| E|Y| for unit Gaussians of correlation t, over 2/pi (section 3.2).
double omega(double t) {
    t = std::clamp(t, -1.0, 1.0);
    return t * std::asin(t) + std::sqrt(1.0 - t * t) - 1.0;
}

} // namespace

double minus_log10_phi(double x) {
    if (x > -30.0) return -std::log10(0.5 * std::erfc(-x / std::sqrt(2.0)));
    // Phi(x) = phi(x) / |x| (1 - 1/x^2 + 3/x^4 - ...), x << 0.
    const double x2 = x * x;
    const double series = 1.0 - 1.0 / x2 + 3.0 / (x2 * x2);
    return (x2 / 2.0 + std::log(-x * std::sqrt(2.0 * kPi)) - std::log(series)) / std::log(10.0);
}

Image grey_level(const Image& u) {
    Image grey(u.width, u.height, 1);
    for (int c = 0; c < u.channels; ++c)
        for (std::size_t i = 0; i < grey.plane_size(); ++i)
            grey.data[i] += u.plane(c)[i] / static_cast<float>(u.channels);
    return grey;
}

// Leclaire and Moisan (JMIV 2015), section 3.2: SI and its closed-form mean and variance.
SharpnessIndex sharpness_index(const Image& u, int threads, bool periodic) {
    SharpnessIndex out;
    const int w = u.width, h = u.height;
    if (w < 2 || h < 2 || u.channels < 1) return out;
    const Image grey = grey_level(u);
    const Image p = periodic ? grey : periodic_component(grey, threads);

    // Periodic finite differences, and the TV they sum to.
    std::vector<float> dx(p.plane_size()), dy(p.plane_size());
    double tv = 0, a2 = 0, b2 = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            dx[i] = p.at(0, (x + 1) % w, y) - p.at(0, x, y);
            dy[i] = p.at(0, x, (y + 1) % h) - p.at(0, x, y);
            tv += std::fabs(dx[i]) + std::fabs(dy[i]);
            a2 += double(dx[i]) * dx[i];
            b2 += double(dy[i]) * dy[i];
        }
    out.tv = tv;
    if (!(a2 > 0.0) || !(b2 > 0.0)) return out; // flat along an axis: no random-phase spread

    // Correlations of the gradients at every lag z: inverse DFT of the (cross) power spectra.
    const auto fft = RealFft2d::get(w, h);
    Spectrum fx(w, h), fy(w, h), sxx(w, h), syy(w, h), sxy(w, h);
    fft->forward(dx.data(), fx, threads);
    fft->forward(dy.data(), fy, threads);
    for (int j = 0; j < h; ++j)
        for (int k = 0; k < fx.cwidth(); ++k) {
            const cfloat gx = fx.row(j)[k], gy = fy.row(j)[k];
            sxx.row(j)[k] = std::norm(gx);
            syy.row(j)[k] = std::norm(gy);
            sxy.row(j)[k] = std::conj(gx) * gy;
        }
    std::vector<float> rxx(p.plane_size()), ryy(p.plane_size()), rxy(p.plane_size());
    fft->inverse(sxx, rxx.data(), threads);
    fft->inverse(syy, ryy.data(), threads);
    fft->inverse(sxy, rxy.data(), threads);
    // Unnormalised inverse: r(z) = sum_t d(t) d(t + z) times MN.
    const double n = static_cast<double>(w) * h;
    const double a = std::sqrt(a2), b = std::sqrt(b2);
    double var = 0;
    for (std::size_t i = 0; i < rxx.size(); ++i)
        var += a2 * omega(rxx[i] / (n * a2)) + b2 * omega(ryy[i] / (n * b2)) +
               2.0 * a * b * omega(rxy[i] / (n * a * b));
    var *= 2.0 / kPi;
    out.mean = std::sqrt(2.0 * n / kPi) * (a + b);
    out.sd = std::sqrt(std::max(var, 0.0));
    if (!(out.sd > 0.0)) return out;
    out.deviation = (out.mean - tv) / out.sd;
    out.index = minus_log10_phi(-out.deviation);
    return out;
}

Image box_reduce(const Image& u, int f) {
    if (f <= 1) return u;
    Image v(u.width / f, u.height / f, u.channels);
    const float inv = 1.0f / static_cast<float>(f * f);
    for (int c = 0; c < u.channels; ++c)
        for (int y = 0; y < v.height; ++y)
            for (int x = 0; x < v.width; ++x) {
                float s = 0;
                for (int j = 0; j < f; ++j)
                    for (int i = 0; i < f; ++i) s += u.at(c, x * f + i, y * f + j);
                v.at(c, x, y) = s * inv;
            }
    return v;
}

Image fast_box_reduce(const Image& u, int f, int least) {
    f = std::max(f, 1);
    const int w = fast_side(u.width / f, least), h = fast_side(u.height / f, least);
    if (w == u.width / f && h == u.height / f) return box_reduce(u, f);
    return box_reduce(centred_part(u, w * f, h * f), f);
}

double coherence_of(const SharpnessIndex& si) {
    return si.mean > 0.0 ? 1.0 - si.tv / si.mean : 0.0;
}

TextureKind texture_kind(double index) {
    if (index > kMacroCoherence) return TextureKind::macro;
    return index > kMicroCoherence ? TextureKind::borderline : TextureKind::micro;
}

TextureKind PhaseCoherence::kind() const {
    return texture_kind(index);
}

PhaseCoherence phase_coherence(const Image& u, int threads) {
    PhaseCoherence out;
    out.full = sharpness_index(u, threads);
    const int shortest = std::min(u.width, u.height);
    std::vector<int> factors;
    for (int side : {128, 64, 32})
        if (shortest >= side) factors.push_back(shortest / side);
    if (factors.empty()) factors.push_back(1);
    for (int f : factors) {
        CoherenceScale s;
        s.factor = f;
        const Image v = f == 1 ? u : box_reduce(u, f);
        s.width = v.width;
        s.height = v.height;
        s.si = f == 1 ? out.full : sharpness_index(v, threads);
        s.coherence = coherence_of(s.si);
        out.index += s.coherence / static_cast<double>(factors.size());
        out.scales.push_back(s);
    }
    return out;
}

} // namespace textond::core
