#include "server/app/quality_report.h"

#include "core/periodic_component.h"
#include "core/power_spectrum.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace textond::app {

namespace {

constexpr int kBins = 64;

// Per-channel histograms over [0, 1] (values outside counted in the end bins), summing to 1.
std::vector<std::vector<double>> histograms(const core::Image& u) {
    std::vector<std::vector<double>> h(static_cast<std::size_t>(u.channels),
                                       std::vector<double>(kBins, 0.0));
    const double n = static_cast<double>(u.plane_size());
    for (int c = 0; c < u.channels; ++c)
        for (std::size_t k = 0; k < u.plane_size(); ++k) {
            const int b = std::clamp(static_cast<int>(u.plane(c)[k] * kBins), 0, kBins - 1);
            h[static_cast<std::size_t>(c)][static_cast<std::size_t>(b)] += 1.0 / n;
        }
    return h;
}

// 1-D Wasserstein distance between two channels' values (same count: sorted, paired).
double wasserstein1(const float* a, const float* b, std::size_t n) {
    std::vector<float> x(a, a + n), y(b, b + n);
    std::sort(x.begin(), x.end());
    std::sort(y.begin(), y.end());
    double s = 0;
    for (std::size_t k = 0; k < n; ++k) s += std::fabs(double(x[k]) - y[k]);
    return s / static_cast<double>(n);
}

// Mean over channels.
double mean_w1(const core::Image& a, const core::Image& b) {
    double s = 0;
    for (int c = 0; c < a.channels; ++c) s += wasserstein1(a.plane(c), b.plane(c), a.plane_size());
    return s / a.channels;
}

// `src` (grey or RGB, clamped to [0, 1]) into `dst` (RGB) at (x0, y0).
void paste(core::Image& dst, const core::Image& src, int x0, int y0) {
    for (int c = 0; c < 3; ++c)
        for (int y = 0; y < src.height; ++y)
            for (int x = 0; x < src.width; ++x)
                dst.at(c, x0 + x, y0 + y) =
                    std::clamp(src.at(std::min(c, src.channels - 1), x, y), 0.0f, 1.0f);
}

// One channel's histograms as curves in a w x h box at (x0, y0): the exemplar white, the
// Gaussian noise blue, the restored noise orange.
void plot(core::Image& dst, int x0, int y0, int w, int h,
          const std::vector<const std::vector<double>*>& curves) {
    static const std::array<std::array<float, 3>, 3> colours = {
        {{1.0f, 1.0f, 1.0f}, {0.3f, 0.6f, 1.0f}, {1.0f, 0.6f, 0.1f}}};
    double peak = 1e-12;
    for (const auto* c : curves)
        if (c) peak = std::max(peak, *std::max_element(c->begin(), c->end()));
    for (std::size_t k = 0; k < curves.size(); ++k) {
        if (!curves[k]) continue;
        const auto& v = *curves[k];
        for (int x = 0; x < w; ++x) {
            const double t = (x + 0.5) / w * kBins - 0.5;
            const int i = std::clamp(static_cast<int>(t), 0, kBins - 2);
            const double f = std::clamp(t - i, 0.0, 1.0);
            const double value =
                (1 - f) * v[static_cast<std::size_t>(i)] + f * v[static_cast<std::size_t>(i + 1)];
            const int y = y0 + h - 1 - static_cast<int>(value / peak * (h - 1));
            for (int dy = 0; dy < 2 && y + dy < y0 + h; ++dy)
                for (int c = 0; c < 3; ++c) dst.at(c, x0 + x, y + dy) = colours[k][c];
        }
    }
}

} // namespace

QualityReport quality_report(const api::TextonMeta& meta, const core::Image& exemplar,
                             const core::Image& gaussian, const core::Image& restored) {
    QualityReport r;
    const auto he = histograms(exemplar), hg = histograms(gaussian);
    const bool has_restored = !restored.empty();
    r.json = {{"id", meta.id},
              {"rme", meta.rme},
              {"verdict", meta.verdict()},
              {"window", {{"width", exemplar.width}, {"height", exemplar.height}}},
              {"histograms",
               {{"bins", kBins}, {"range", {0.0, 1.0}}, {"exemplar", he}, {"gaussian", hg}}},
              {"wasserstein", {{"gaussian", mean_w1(exemplar, gaussian)}}}};
    if (meta.phase_coherence) {
        r.json["phase_coherence"] = *meta.phase_coherence;
        r.json["sharpness_index"] = meta.sharpness_index.value_or(0.0);
    }
    if (meta.shape_score) r.json["shape_score"] = *meta.shape_score;
    if (!meta.kind().empty()) r.json["kind"] = meta.kind();
    std::vector<std::vector<double>> hr;
    if (has_restored) {
        hr = histograms(restored);
        r.json["histograms"]["restored"] = hr;
        r.json["wasserstein"]["restored"] = mean_w1(exemplar, restored);
    }

    // Row 1: exemplar | Gaussian noise | restored noise. Row 2: the power spectra of the
    // exemplar and of the Gaussian noise on one log scale. Row 3: a histogram box per channel.
    const int w = exemplar.width, h = exemplar.height, gap = 4, hist_h = 96;
    const core::Image pe = core::centred_power_spectrum(core::periodic_component(exemplar));
    const core::Image pg = core::centred_power_spectrum(gaussian);
    const double top = std::max(core::log10_max(pe), core::log10_max(pg));
    const int width = 3 * w + 2 * gap;
    r.png = core::Image(width, 2 * h + hist_h + 2 * gap, 3, 0.1f);
    paste(r.png, exemplar, 0, 0);
    paste(r.png, gaussian, w + gap, 0);
    if (has_restored) paste(r.png, restored, 2 * (w + gap), 0);
    paste(r.png, core::log_display(pe, top, 5.0), 0, h + gap);
    paste(r.png, core::log_display(pg, top, 5.0), w + gap, h + gap);
    const int box = (width - (exemplar.channels - 1) * gap) / exemplar.channels;
    for (int c = 0; c < exemplar.channels; ++c) {
        const auto uc = static_cast<std::size_t>(c);
        plot(r.png, c * (box + gap), 2 * (h + gap), box, hist_h,
             {&he[uc], &hg[uc], has_restored ? &hr[uc] : nullptr});
    }
    r.json["png_layout"] =
        "row 1: exemplar, Gaussian noise, noise with the exemplar's marginals; row 2: power "
        "spectra of the exemplar and of the noise (log, five decades); row 3: per-channel "
        "histograms (white exemplar, blue Gaussian, orange restored)";
    return r;
}

} // namespace textond::app
