#include "core/shape_verdict.h"

#include "core/fft2d.h"
#include "core/periodic_component.h"
#include "core/random.h"
#include "core/spectral_filter.h"
#include "core/working_window.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace textond::core {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kLineOrientations = 4;

// The filters every statistic applies, for one image size: the same for the exemplar and every
// null sample, so each is sampled once a verdict (their exp and sin were most of its time).
struct Filters {
    Transfer grad_x, grad_y;     // central differences at sigma 1
    Transfer smooth;             // Gaussian, sigma 2 (the structure tensor's window)
    std::vector<Transfer> lines; // derivative across, Gaussian along, kLineOrientations of them
    Transfer speck;              // difference of Gaussians, sigma 1 and 2

    Filters(int w, int h) {
        auto grad = [&](bool along_x) {
            return sampled_transfer(w, h, [&](double wx, double wy) {
                const double g = gaussian_response(wx, wy, 1.0);
                return cfloat(0.0f, static_cast<float>(g * std::sin(along_x ? wx : wy)));
            });
        };
        grad_x = grad(true);
        grad_y = grad(false);
        smooth = sampled_transfer(w, h, [](double wx, double wy) {
            return cfloat(static_cast<float>(gaussian_response(wx, wy, 2.0)), 0.0f);
        });
        for (int k = 0; k < kLineOrientations; ++k) {
            const double th = kPi * k / kLineOrientations, c = std::cos(th), s = std::sin(th);
            lines.push_back(sampled_transfer(w, h, [&](double wx, double wy) {
                const double across = wx * c + wy * s, along = -wx * s + wy * c;
                const double g = std::exp(-0.5 * (across * across + 16.0 * along * along));
                return cfloat(0.0f, static_cast<float>(across * g));
            }));
        }
        speck = sampled_transfer(w, h, [](double wx, double wy) {
            return cfloat(
                static_cast<float>(gaussian_response(wx, wy, 1.0) - gaussian_response(wx, wy, 2.0)),
                0.0f);
        });
    }
};

// Structure tensor anisotropy: gradient (central differences) at sigma 1, tensor at sigma 2.
double tensor_anisotropy(const Spectrum& spec, const RealFft2d& fft, const Filters& f,
                         int threads) {
    return structure_tensor_anisotropy(filtered(spec, fft, threads, f.grad_x),
                                       filtered(spec, fft, threads, f.grad_y), fft, threads,
                                       f.smooth);
}

// The largest line-filter kurtosis over the orientations (derivative across, Gaussian along).
double line_kurtosis(const Spectrum& spec, const RealFft2d& fft, const Filters& f, int threads) {
    double best = -1e300;
    for (const Transfer& t : f.lines)
        best = std::max(best, band_moments(filtered(spec, fft, threads, t)).log_kurtosis);
    return best;
}

double speck_kurtosis(const Spectrum& spec, const RealFft2d& fft, const Filters& f, int threads) {
    return band_moments(filtered(spec, fft, threads, f.speck)).log_kurtosis;
}

double tv_coherence(const Image& grey) {
    const int f = 4;
    if (grey.width < 2 * f || grey.height < 2 * f) return 0.0;
    return coherence_of(sharpness_index(box_reduce(grey, f), 1, /*periodic=*/true));
}

ShapeStatistics statistics_of(const Image& grey, const Spectrum& spec, const RealFft2d& fft,
                              const Filters& f, int threads) {
    ShapeStatistics s;
    s.tensor = tensor_anisotropy(spec, fft, f, threads);
    s.tv = tv_coherence(grey);
    s.lines = line_kurtosis(spec, fft, f, threads);
    s.specks = speck_kurtosis(spec, fft, f, threads);
    return s;
}

double weighted(const ShapeStatistics& e) {
    const ShapeWeights& w = kShapeWeights;
    return w.bias + w.tensor * e.tensor + w.tv * e.tv + w.lines * e.lines + w.specks * e.specks;
}

// The verdict of one measured image, at least 16 pixels a side: its statistics, their excess
// over its ADSN null, the score. `filters` are sampled for its size, once for both scales.
void measure(const Image& grey, const Filters& filters, int threads, std::uint64_t seed,
             int samples, ShapeVerdict& out) {
    const auto fft = RealFft2d::get(grey.width, grey.height);
    Spectrum spec(grey.width, grey.height);
    fft->forward(grey.data.data(), spec, threads);
    spec.row(0)[0] = 0; // the mean: no statistic sees it
    out.exemplar = statistics_of(grey, spec, *fft, filters, threads);

    // ADSN (TIP 2011, Theorem 2): the exemplar's spectrum times white noise's, over sqrt(|Omega|).
    const double n = static_cast<double>(grey.plane_size());
    std::vector<ShapeStatistics> null;
    Rng rng(seed, 0x5ba9e);
    Image sample(grey.width, grey.height, 1);
    for (int k = 0; k < samples; ++k) {
        for (float& v : sample.data) v = static_cast<float>(rng.normal());
        Spectrum z(grey.width, grey.height);
        fft->forward(sample.data.data(), z, threads);
        const float scale = static_cast<float>(1.0 / std::sqrt(n));
        for (int i = 0; i < grey.height; ++i)
            for (int j = 0; j < z.cwidth(); ++j) z.row(i)[j] *= spec.row(i)[j] * scale;
        Spectrum copy = z;
        fft->inverse(copy, sample.data.data(), threads);
        for (float& v : sample.data) v /= static_cast<float>(n);
        null.push_back(statistics_of(sample, z, *fft, filters, threads));
    }
    for (double ShapeStatistics::*field : {&ShapeStatistics::tensor, &ShapeStatistics::tv,
                                           &ShapeStatistics::lines, &ShapeStatistics::specks}) {
        double mean = 0, m2 = 0;
        for (const auto& s : null) mean += s.*field / samples;
        for (const auto& s : null) m2 += (s.*field - mean) * (s.*field - mean);
        out.null_mean.*field = mean;
        out.null_sd.*field = samples > 1 ? std::sqrt(m2 / (samples - 1)) : 0.0;
        out.excess.*field = out.exemplar.*field - mean;
    }
    out.score = weighted(out.excess);
    // Values past float's range (an EXR of 1e20s) overflow the tensor: no measurement, as for a
    // tiny image, rather than a NaN that no JSON reader takes back.
    if (!std::isfinite(out.score)) out.score = weighted(ShapeStatistics{});
}

} // namespace

TextureKind shape_kind(double score) {
    if (score > kShapeBand) return TextureKind::macro;
    return score > -kShapeBand ? TextureKind::borderline : TextureKind::micro;
}

TextureKind ShapeVerdict::kind() const {
    return shape_kind(score);
}

ShapeVerdict shape_verdict(const Image& u, int threads, std::uint64_t seed, int samples) {
    samples = std::max(samples, 1);
    ShapeVerdict out;
    out.factor = std::max(1, std::min(u.width, u.height) / 256);
    const Image whole = periodic_component(grey_level(fast_box_reduce(u, out.factor)), threads);
    out.width = whole.width;
    out.height = whole.height;
    out.score = weighted(out.excess); // no excess: a Gaussian texture's score
    if (whole.width < 16 || whole.height < 16) {
        out.scales.push_back({out.factor, out.score});
        return out;
    }
    const Filters filters(whole.width, whole.height);
    measure(whole, filters, threads, seed, samples, out);
    out.scales.push_back({out.factor, out.score});
    if (out.factor == 1) return out;
    // The centred part of the same size at full resolution: shapes a few pixels across, which
    // the reduction blurs into specks. Photographed grain is as sharp there, so this scale must
    // clear kFineScaleOffset more (core/README.md "Micro or macro", "Two scales").
    ShapeVerdict fine;
    fine.factor = 1;
    fine.width = out.width;
    fine.height = out.height;
    measure(periodic_component(grey_level(centred_part(u, out.width, out.height)), threads),
            filters, threads, seed, samples, fine);
    out.scales.push_back({1, fine.score});
    fine.score -= kFineScaleOffset;
    if (fine.score > out.score) {
        fine.scales = std::move(out.scales);
        return fine;
    }
    return out;
}

} // namespace textond::core
