#include "core/texture_mix.h"

#include "core/periodic_component.h"
#include "core/placed_image.h"
#include "core/working_window.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>

namespace textond::core {

namespace {

Image centre_crop_rgb(const Image& src, int w, int h, int channels) {
    Image out(w, h, channels);
    const int ox = (src.width - w) / 2, oy = (src.height - h) / 2;
    for (int c = 0; c < channels; ++c) {
        const int sc = src.channels == 1 ? 0 : c;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) out.at(c, x, y) = src.at(sc, ox + x, oy + y);
    }
    return out;
}

} // namespace

std::array<int, 2> mix_grid(int uw, int uh, int vw, int vh, int least) {
    return window_size(std::min(uw, vw), std::min(uh, vh), kWorkingSide, least);
}

Result<ModelPair> common_models(const Image& u, const Image& v, bool periodic, int threads,
                                int least) {
    for (const Image* e : {&u, &v})
        if ((e->channels != 1 && e->channels != 3) || e->width < 2 || e->height < 2)
            return make_error(ErrorCode::invalid_argument,
                              "mix exemplars must be grey or RGB images of at least 2x2");
    const auto [w, h] = mix_grid(u.width, u.height, v.width, v.height, least);
    const int nc = std::max(u.channels, v.channels);
    const Image cu = centre_crop_rgb(u, w, h, nc), cv = centre_crop_rgb(v, w, h, nc);
    ModelPair p;
    p.u = estimate_gaussian_model(periodic ? periodic_component(cu, threads) : cu, threads);
    p.v = estimate_gaussian_model(periodic ? periodic_component(cv, threads) : cv, threads);
    return p;
}

GaussianModel barycentre_model(const ModelPair& pair, double rho, int threads) {
    const GaussianModel& u = pair.u;
    const GaussianModel& v = pair.v;
    const int w = u.width, h = u.height, nc = u.channels, cw = w / 2 + 1;
    GaussianModel m;
    m.width = w;
    m.height = h;
    m.channels = nc;
    for (int c = 0; c < nc; ++c) {
        const auto ci = static_cast<std::size_t>(c);
        m.mean[ci] = (1.0 - rho) * u.mean[ci] + rho * v.mean[ci];
        m.t_hat.emplace_back(w, h);
    }
    for (int i = 0; i < h; ++i)
        for (int j = 0; j < cw; ++j) {
            std::complex<double> s = 0.0;
            for (int c = 0; c < nc; ++c) {
                const auto ci = static_cast<std::size_t>(c);
                s += std::conj(std::complex<double>(u.t_hat[ci].row(i)[j])) *
                     std::complex<double>(v.t_hat[ci].row(i)[j]);
            }
            const double mag = std::abs(s);
            const std::complex<double> phase = mag > 0.0 ? s / mag : 1.0;
            for (int c = 0; c < nc; ++c) {
                const auto ci = static_cast<std::size_t>(c);
                const std::complex<double> tau0 =
                    phase * std::complex<double>(u.t_hat[ci].row(i)[j]);
                const std::complex<double> tau =
                    (1.0 - rho) * tau0 + rho * std::complex<double>(v.t_hat[ci].row(i)[j]);
                m.t_hat[ci].row(i)[j] =
                    cfloat(static_cast<float>(tau.real()), static_cast<float>(tau.imag()));
            }
        }
    // The kernel itself and its colour covariance (what the colour correction restores).
    const auto fft = RealFft2d::get(w, h);
    m.t_u = Image(w, h, nc);
    const float inv_n = 1.0f / (static_cast<float>(w) * static_cast<float>(h));
    for (int c = 0; c < nc; ++c) {
        Spectrum copy = m.t_hat[static_cast<std::size_t>(c)];
        float* t = m.t_u.plane(c);
        fft->inverse(copy, t, threads);
        for (std::size_t k = 0; k < m.t_u.plane_size(); ++k) t[k] *= inv_n;
    }
    m.covariance.n = nc;
    for (int c = 0; c < nc; ++c)
        for (int d = 0; d <= c; ++d)
            m.covariance(c, d) = m.covariance(d, c) =
                plane_dot(m.t_u.plane(c), m.t_u.plane(d), m.t_u.plane_size());
    return m;
}

Result<MixLevels> mix_levels(const ModelPair& pair, const AnalysisParams& params, int levels,
                             const std::function<void(int, int)>& progress) {
    if (levels < 2 || levels > kMaxMixLevels)
        return make_error(ErrorCode::invalid_argument,
                          "levels must be in 2.." + std::to_string(kMaxMixLevels));
    if (auto err = validate_analysis(params, pair.u.width, pair.u.height, pair.u.channels))
        return *err;
    MixLevels out;
    for (int l = 0; l < levels; ++l) {
        const double rho = static_cast<double>(l) / (levels - 1);
        const GaussianModel model = barycentre_model(pair, rho, resolve_threads(params.threads));
        AnalysisResult r = texton_from_model(model, params);
        out.levels.push_back(std::move(r.texton));
        out.rme.push_back(r.rme);
        if (progress) progress(l + 1, levels);
    }
    return out;
}

Image mask_from_image(const Image& img) {
    Image m(img.width, img.height, 1);
    for (std::size_t k = 0; k < m.plane_size(); ++k) {
        double s = 0;
        for (int c = 0; c < img.channels; ++c) s += img.plane(c)[k];
        const double v = s / img.channels; // NaN (a float EXR mask) counts as 0
        m.plane(0)[k] = static_cast<float>(v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0);
    }
    return m;
}

double MixField::rho(double x, double y) const {
    double r;
    if (kind == Kind::ramp) {
        // The unit direction first: (x - x0) * dx could overflow where (x - x0) * (dx / n) cannot
        // (|x - x0| <= 2^63 and |dx / n| <= 1).
        const double n = std::hypot(dx, dy);
        r = ((x - x0) * (dx / n) + (y - y0) * (dy / n)) / width;
    } else {
        sample_placed(mask, x0, y0, scale, x, y, &r);
    }
    // NaN-safe clamp: std::clamp lets NaN through, and a NaN rho would index past the levels.
    if (!(r > 0.0)) return 0.0;
    return r < 1.0 ? r : 1.0;
}

std::optional<Error> MixField::validate() const {
    auto bad = [](const std::string& m) { return make_error(ErrorCode::invalid_argument, m); };
    const double lim = std::ldexp(1.0, 62); // the plane
    if (!std::isfinite(x0) || !std::isfinite(y0) || std::fabs(x0) > lim || std::fabs(y0) > lim)
        return bad("field origin must be finite and within the plane (|x|, |y| <= 2^62)");
    if (kind == Kind::ramp) {
        const double n = std::hypot(dx, dy);
        if (!std::isfinite(dx) || !std::isfinite(dy) || !std::isfinite(n) || !(n > 0.0) ||
            !std::isfinite(dx / n) || !std::isfinite(dy / n))
            return bad("ramp direction must be a finite non-zero vector of finite length");
        if (!std::isfinite(width) || width < 1.0 || width > lim)
            return bad("ramp width must be in [1, 2^62] texels");
        return std::nullopt;
    }
    if (mask.channels != 1 || mask.width < 1 || mask.height < 1)
        return bad("mask must be a one-channel image");
    if (!std::isfinite(scale) || scale < 1.0 / 16 || scale > 1e9)
        return bad("mask scale must be in [1/16, 1e9] texels per mask pixel");
    // A stored mask is read back from a file: every value must still be a weight.
    for (float v : mask.data)
        if (!(v >= 0.0f && v <= 1.0f)) return bad("mask values must be numbers in [0, 1]");
    return std::nullopt;
}

} // namespace textond::core
