#include "core/band_kurtosis.h"

#include "core/fft2d.h"
#include "core/phase_coherence.h"
#include "core/random.h"

#include <algorithm>
#include <cmath>

namespace textond::core {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The kurtosis of the DoG band of `spec` at sigma (spec is left intact).
double band_of(const Spectrum& spec, const RealFft2d& fft, double sigma, int threads) {
    const int w = spec.width(), h = spec.height(), cw = spec.cwidth();
    Spectrum band(w, h);
    for (int i = 0; i < h; ++i) {
        const double fy = (i <= h / 2 ? i : i - h) / static_cast<double>(h);
        for (int j = 0; j < cw; ++j) {
            const double fx = j / static_cast<double>(w);
            const double r2 = 2.0 * kPi * kPi * (fx * fx + fy * fy);
            const double g = std::exp(-r2 * sigma * sigma) - std::exp(-r2 * 4.0 * sigma * sigma);
            band.row(i)[j] = spec.row(i)[j] * static_cast<float>(g);
        }
    }
    std::vector<float> b(static_cast<std::size_t>(w) * h);
    fft.inverse(band, b.data(), threads);
    double m2 = 0, m4 = 0;
    for (float v : b) {
        const double s = static_cast<double>(v) * v;
        m2 += s;
        m4 += s * s;
    }
    m2 /= static_cast<double>(b.size());
    m4 /= static_cast<double>(b.size());
    return m2 > 0 ? m4 / (m2 * m2) : 3.0;
}

} // namespace

std::vector<BandKurtosis> band_kurtosis(const Image& u, int samples, std::uint64_t seed,
                                        int threads) {
    const int w = u.width, h = u.height;
    std::vector<BandKurtosis> out;
    if (w < 8 || h < 8) return out;
    const auto fft = RealFft2d::get(w, h);
    const Image g = grey_level(u);
    Spectrum spec(w, h);
    fft->forward(g.data.data(), spec, threads);
    spec.row(0)[0] = 0; // the mean
    // Random phases with the symmetry of a real image: those of white noise's spectrum.
    std::vector<Spectrum> rpn;
    Rng rng(seed, 0xba4d);
    for (int s = 0; s < samples; ++s) {
        std::vector<float> noise(g.plane_size());
        for (auto& v : noise) v = static_cast<float>(rng.normal());
        Spectrum phase(w, h);
        fft->forward(noise.data(), phase, threads);
        for (int i = 0; i < h; ++i)
            for (int j = 0; j < spec.cwidth(); ++j) {
                const float m = std::abs(phase.row(i)[j]);
                phase.row(i)[j] =
                    m > 0 ? std::abs(spec.row(i)[j]) * (phase.row(i)[j] / m) : cfloat();
            }
        rpn.push_back(std::move(phase));
    }
    const int short_side = std::min(w, h);
    for (double sigma = 1; 4 * sigma <= short_side / 4.0; sigma *= 2) {
        BandKurtosis k;
        k.sigma = sigma;
        k.kurtosis = band_of(spec, *fft, sigma, threads);
        for (const Spectrum& r : rpn) k.random_phase += band_of(r, *fft, sigma, threads) / samples;
        k.log_ratio = std::log(k.kurtosis / k.random_phase);
        out.push_back(k);
    }
    return out;
}

} // namespace textond::core
