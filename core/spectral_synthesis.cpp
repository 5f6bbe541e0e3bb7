#include "core/spectral_synthesis.h"

#include "core/bspline.h"
#include "core/periodic_component.h"
#include "core/random.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace textond::core {

namespace {
// Smooth transition of RPN paper Fig. 9: 1 in the middle, Gaussian fall-off (sigma = a / 4) on
// the outer fraction a of each side.
std::vector<double> transition_profile(int n, double a) {
    std::vector<double> f(static_cast<std::size_t>(n), 1.0);
    if (a <= 0.0) return f;
    const double sigma = a / 4.0;
    for (int x = 0; x < n; ++x) {
        const double t = (x + 0.5) / n;
        double d = 0.0;
        if (t < a)
            d = a - t;
        else if (t > 1.0 - a)
            d = t - (1.0 - a);
        f[static_cast<std::size_t>(x)] = std::exp(-d * d / (2.0 * sigma * sigma));
    }
    return f;
}

Image crop(const Image& in, int width, int height) {
    if (in.width == width && in.height == height) return in;
    Image out(width, height, in.channels);
    for (int c = 0; c < in.channels; ++c)
        for (int y = 0; y < height; ++y)
            std::copy_n(in.plane(c) + static_cast<std::size_t>(y) * in.width, width,
                        out.plane(c) + static_cast<std::size_t>(y) * width);
    return out;
}

std::vector<Spectrum> spectra_of(const Image& t, int threads) {
    const auto fft = RealFft2d::get(t.width, t.height);
    std::vector<Spectrum> out;
    for (int c = 0; c < t.channels; ++c) {
        out.emplace_back(t.width, t.height);
        fft->forward(t.plane(c), out.back(), threads);
    }
    return out;
}
} // namespace

Image spot_extension(const Image& p, const ChannelValues& mean, int width, int height,
                     double transition) {
    if (width < p.width || height < p.height)
        throw std::invalid_argument("spot_extension: domain smaller than the spot");
    Image t(width, height, p.channels);
    const bool same = width == p.width && height == p.height;
    const auto fx = transition_profile(p.width, same ? 0.0 : transition);
    const auto fy = transition_profile(p.height, same ? 0.0 : transition);
    double energy = 0.0;
    for (int y = 0; y < p.height; ++y)
        for (int x = 0; x < p.width; ++x) {
            const double f = fx[static_cast<std::size_t>(x)] * fy[static_cast<std::size_t>(y)];
            energy += f * f;
        }
    // (p - m) phi / sqrt(sum phi^2): phi at unit mean square keeps the spot's variance, and the
    // 1/sqrt(|R1|) of t_u is folded in.
    const double scale = 1.0 / std::sqrt(energy);
    const int ox = (width - p.width) / 2, oy = (height - p.height) / 2;
    for (int c = 0; c < p.channels; ++c)
        for (int y = 0; y < p.height; ++y)
            for (int x = 0; x < p.width; ++x) {
                const double f = fx[static_cast<std::size_t>(x)] * fy[static_cast<std::size_t>(y)];
                t.at(c, x + ox, y + oy) = static_cast<float>(
                    (p.at(c, x, y) - mean[static_cast<std::size_t>(c)]) * f * scale);
            }
    return t;
}

Image spectral_synthesis(std::vector<Spectrum> k_hat, const ChannelValues& mean,
                         SpectralMethod method, std::uint64_t seed, int threads) {
    if (k_hat.empty()) throw std::invalid_argument("spectral_synthesis: no channels");
    const int w = k_hat[0].width(), h = k_hat[0].height(), cw = w / 2 + 1;
    const auto fft = RealFft2d::get(w, h);
    Spectrum noise(w, h);
    {
        std::vector<float> white(static_cast<std::size_t>(w) * h);
        Rng rng(seed, 0xad5);
        for (auto& v : white) v = static_cast<float>(rng.normal());
        fft->forward(white.data(), noise, threads);
    }
    const float rpn_gain = static_cast<float>(std::sqrt(static_cast<double>(w) * h));
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < cw; ++j) {
            cfloat n = noise.row(i)[j];
            if (method == SpectralMethod::rpn) {
                const float mag = std::abs(n);
                n = mag > 0.0f ? n / mag * rpn_gain : cfloat(rpn_gain, 0.0f);
            }
            // RPN keeps the mean exactly (theta(0) = 0 and no DC term); ADSN keeps it on average.
            if (i == 0 && j == 0 && method == SpectralMethod::rpn) n = cfloat();
            for (auto& k : k_hat) k.row(i)[j] *= n;
        }
    Image out(w, h, static_cast<int>(k_hat.size()));
    const float inv_n = 1.0f / (static_cast<float>(w) * static_cast<float>(h));
    for (int c = 0; c < out.channels; ++c) {
        float* p = out.plane(c);
        fft->inverse(k_hat[static_cast<std::size_t>(c)], p, threads);
        const float m = static_cast<float>(mean[static_cast<std::size_t>(c)]);
        for (std::size_t k = 0; k < out.plane_size(); ++k) p[k] = p[k] * inv_n + m;
    }
    return out;
}

Image synthesize_from_exemplar(const Image& exemplar, SpectralMethod method, int width, int height,
                               std::uint64_t seed, int threads) {
    if (width <= 0 || height <= 0) throw std::invalid_argument("synthesis: empty output size");
    const Image p = periodic_component(exemplar, threads);
    ChannelValues mean{};
    for (int c = 0; c < p.channels; ++c) {
        double s = 0.0;
        for (std::size_t k = 0; k < p.plane_size(); ++k) s += p.plane(c)[k];
        mean[static_cast<std::size_t>(c)] = s / static_cast<double>(p.plane_size());
    }
    const int dw = std::max(width, p.width), dh = std::max(height, p.height);
    const Image t = spot_extension(p, mean, dw, dh);
    return crop(spectral_synthesis(spectra_of(t, threads), mean, method, seed, threads), width,
                height);
}

Image synthesize_from_texton(const Texton& texton, SpectralMethod method, int width, int height,
                             std::uint64_t seed, int threads) {
    if (width <= 0 || height <= 0) throw std::invalid_argument("synthesis: empty output size");
    // Any domain at least r - 1 larger than the output works; one with small prime factors keeps
    // FFTW fast (1024 + 63 = 1087 is prime: 40x slower than 1120).
    const int dw = fft_friendly_size(width + texton.size - 1);
    const int dh = fft_friendly_size(height + texton.size - 1), cw = dw / 2 + 1;
    const auto fft = RealFft2d::get(dw, dh);
    const std::vector<float> sqrtb = sqrt_bhat_grid(texton.order, dw, dh);
    std::vector<Spectrum> k_hat;
    for (int c = 0; c < texton.channels; ++c) {
        k_hat.emplace_back(dw, dh);
        fft->forward(texton.alpha.plane(c), static_cast<std::size_t>(texton.size), texton.size,
                     texton.size, k_hat.back(), threads);
        for (int i = 0; i < dh; ++i)
            for (int j = 0; j < cw; ++j)
                k_hat.back().row(i)[j] *= sqrtb[static_cast<std::size_t>(i) * cw + j];
    }
    return crop(spectral_synthesis(std::move(k_hat), texton.mean, method, seed, threads), width,
                height);
}

} // namespace textond::core
