#include "core/texton_analysis.h"

#include "core/bspline.h"
#include "core/periodic_component.h"
#include "core/random.h"
#include "core/rme.h"

#include <chrono>
#include <cmath>
#include <string>

namespace textond::core {

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
} // namespace

std::optional<Error> validate_analysis(const AnalysisParams& p, int width, int height,
                                       int channels) {
    if (channels != 1 && channels != 3)
        return make_error(ErrorCode::invalid_argument,
                          "exemplar must have 1 or 3 channels, not " + std::to_string(channels));
    if (!valid_interpolation_order(p.order))
        return make_error(ErrorCode::invalid_argument,
                          "order must be 0, 1 or 3, not " + std::to_string(p.order));
    if (p.iterations < 1 || p.iterations > 1000)
        return make_error(ErrorCode::invalid_argument,
                          "iterations must be in 1..1000, not " + std::to_string(p.iterations));
    if (p.size < 8 || p.size > 256)
        return make_error(ErrorCode::invalid_argument,
                          "size must be in 8..256, not " + std::to_string(p.size));
    const int short_side = width < height ? width : height;
    if (2 * p.size > short_side)
        return make_error(ErrorCode::invalid_argument,
                          "size " + std::to_string(p.size) +
                              " is larger than half the exemplar's short side (" +
                              std::to_string(width) + "x" + std::to_string(height) + ")");
    if (p.threads < 0) return make_error(ErrorCode::invalid_argument, "threads must be >= 0");
    return std::nullopt;
}

Image alternating_projections(const GaussianModel& model, int size, int order, int iterations,
                              std::uint64_t seed, int threads, const ProgressFn& progress) {
    const int w = model.width, h = model.height, nc = model.channels, cw = w / 2 + 1;
    threads = resolve_threads(threads);
    const auto fft = RealFft2d::get(w, h);
    const std::vector<float> sqrtb = sqrt_bhat_grid(order, w, h);

    // Spectral target t_u^ / sqrt(b^) (eq. (4)).
    std::vector<Spectrum> target = model.t_hat;
    for (auto& s : target)
        for (int i = 0; i < h; ++i)
            for (int j = 0; j < cw; ++j) s.row(i)[j] /= sqrtb[static_cast<std::size_t>(i) * cw + j];

    // Random start: white Gaussian noise (Algorithm 1). Its spectral projection only keeps the
    // phase of sum_c conj(target_c) noise_c^, which is a uniform random phase whatever the
    // number of noise channels, so one noise plane gives the same distribution.
    Spectrum phase(w, h);
    {
        std::vector<float> noise(static_cast<std::size_t>(w) * h);
        Rng rng(seed, 0x5eed);
        for (auto& v : noise) v = static_cast<float>(rng.normal());
        fft->forward(noise.data(), phase, threads);
    }

    std::vector<Spectrum> coeff(static_cast<std::size_t>(nc), Spectrum(w, h));
    Image alpha(size, size, nc);
    const float inv_n = 1.0f / (static_cast<float>(w) * static_cast<float>(h));
    const std::size_t rs = static_cast<std::size_t>(size);

    for (int it = 1; it <= iterations; ++it) {
        // 1. Impose the spectrum: alpha^ <- (t^* alpha^ / |t^* alpha^|) t^ (one phase for all
        //    channels; where t^* alpha^ = 0, alpha^ = 0). Rows are independent: any thread split
        //    gives the same bits.
#pragma omp parallel for num_threads(threads) schedule(static)
        for (int i = 0; i < h; ++i) {
            const cfloat* tr[kMaxChannels] = {};
            cfloat* cr[kMaxChannels] = {};
            for (int c = 0; c < nc; ++c) {
                tr[c] = target[static_cast<std::size_t>(c)].row(i);
                cr[c] = coeff[static_cast<std::size_t>(c)].row(i);
            }
            const cfloat* ph = phase.row(i);
            for (int j = 0; j < cw; ++j) {
                cfloat s;
                if (it == 1) {
                    s = ph[j];
                } else {
                    s = cfloat();
                    for (int c = 0; c < nc; ++c) s += std::conj(tr[c][j]) * cr[c][j];
                }
                // sqrt(norm) rather than std::abs: no hypot() on the hot path; the values are
                // far from overflow.
                const float mag = std::sqrt(std::norm(s));
                const cfloat u = mag > 0.0f ? s * (1.0f / mag) : cfloat();
                for (int c = 0; c < nc; ++c) cr[c][j] = u * tr[c][j];
            }
        }
        // 2. Impose the support: only the r x r corner of the inverse is kept. The inverse may
        //    destroy coeff: the next forward transform rewrites it.
        for (int c = 0; c < nc; ++c) {
            float* a = alpha.plane(c);
            fft->inverse(coeff[static_cast<std::size_t>(c)], a, rs, size, size, threads);
            for (std::size_t k = 0; k < alpha.plane_size(); ++k) a[k] *= inv_n;
            if (it < iterations)
                fft->forward(a, rs, size, size, coeff[static_cast<std::size_t>(c)], threads);
        }
        if (progress) progress(it, iterations);
    }
    return alpha;
}

ColourMatrix colour_correction_matrix(const ColourMatrix& c_u, const ColourMatrix& c_alpha) {
    return multiply(sqrt_psd(c_u), pinv_sqrt_psd(c_alpha));
}

void apply_colour_matrix(Image& alpha, const ColourMatrix& a) {
    const int nc = alpha.channels;
    const std::size_t n = alpha.plane_size();
    std::vector<double> v(static_cast<std::size_t>(nc));
    for (std::size_t k = 0; k < n; ++k) {
        for (int c = 0; c < nc; ++c) v[static_cast<std::size_t>(c)] = alpha.plane(c)[k];
        for (int c = 0; c < nc; ++c) {
            double s = 0.0;
            for (int d = 0; d < nc; ++d) s += a(c, d) * v[static_cast<std::size_t>(d)];
            alpha.plane(c)[k] = static_cast<float>(s);
        }
    }
}

Result<AnalysisResult> analyze_texton(const Image& exemplar, const AnalysisParams& params,
                                      const ProgressFn& progress) {
    if (auto err = validate_analysis(params, exemplar.width, exemplar.height, exemplar.channels))
        return *err;
    const auto t_start = std::chrono::steady_clock::now();
    const int threads = resolve_threads(params.threads);
    AnalysisResult out;

    auto t0 = std::chrono::steady_clock::now();
    // SOT paper section 3.1, on the working window of a large exemplar: every step below, the
    // verdict and the marginals too, looks at the window alone.
    const Image crop = working_window(exemplar, params.working_side, 2 * params.size);
    const Image& window = crop.empty() ? exemplar : crop;
    const Image p = params.periodic ? periodic_component(window, threads) : window;
    out.timings.periodic_ms = ms_since(t0);

    t0 = std::chrono::steady_clock::now();
    const GaussianModel model = estimate_gaussian_model(p, threads);
    out.timings.model_ms = ms_since(t0);
    AnalysisResult r = texton_from_model(model, params, progress);
    r.timings.periodic_ms = out.timings.periodic_ms;
    r.timings.model_ms = out.timings.model_ms;
    t0 = std::chrono::steady_clock::now();
    r.coherence = phase_coherence(window, threads);
    r.timings.coherence_ms = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    r.shape = shape_verdict(window, threads);
    r.timings.shape_ms = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    r.texton.marginals = marginal_model(window);
    r.timings.marginals_ms = ms_since(t0);
    r.timings.total_ms = ms_since(t_start);
    return r;
}

AnalysisResult texton_from_model(const GaussianModel& model, const AnalysisParams& params,
                                 const ProgressFn& progress) {
    const int threads = resolve_threads(params.threads);
    AnalysisResult out;
    auto t0 = std::chrono::steady_clock::now();
    Image alpha = alternating_projections(model, params.size, params.order, params.iterations,
                                          params.seed, threads, progress);
    out.timings.projections_ms = ms_since(t0);

    t0 = std::chrono::steady_clock::now();
    out.rme_uncorrected = relative_model_error(model, alpha, params.order, 0, 0, threads);
    out.timings.rme_ms = ms_since(t0);

    t0 = std::chrono::steady_clock::now();
    out.correction =
        colour_correction_matrix(model.covariance, texton_noise_covariance(alpha, params.order));
    apply_colour_matrix(alpha, out.correction);
    out.timings.correction_ms = ms_since(t0);

    t0 = std::chrono::steady_clock::now();
    out.rme = relative_model_error(model, alpha, params.order, 0, 0, threads);
    out.timings.rme_ms += ms_since(t0);

    out.texton.size = params.size;
    out.texton.channels = model.channels;
    out.texton.order = params.order;
    out.texton.mean = model.mean;
    out.texton.alpha = std::move(alpha);
    return out;
}

} // namespace textond::core
