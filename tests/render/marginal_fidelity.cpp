#include "tests/render/marginal_fidelity.h"

#include "core/gaussian_model.h"
#include "core/periodic_component.h"
#include "core/rme.h"
#include "core/texton_analysis.h"
#include "render/cpu_backend.h"
#include "tests/support/test_support.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace textond::test {

namespace {

// The image's values along principal direction i of `m` (centred on the exemplar's mean).
std::vector<double> component(const core::Image& u, const core::MarginalModel& m, int i) {
    std::vector<double> y(u.plane_size());
    for (std::size_t k = 0; k < y.size(); ++k) {
        double s = 0;
        for (int c = 0; c < m.channels; ++c)
            s += m.basis(c, i) * (u.plane(c)[k] - m.mean[static_cast<std::size_t>(c)]);
        y[k] = s;
    }
    return y;
}

double spectrum_rme(const core::GaussianModel& exemplar, const core::Image& noise) {
    const core::GaussianModel n = core::estimate_gaussian_model(core::periodic_component(noise));
    return core::relative_model_error(exemplar.t_hat, n.t_hat);
}

} // namespace

double wasserstein1(std::vector<double> a, std::vector<double> b) {
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    const int k = 1000;
    double s = 0;
    for (int j = 0; j < k; ++j) {
        const double p = (j + 0.5) / k;
        s += std::fabs(a[static_cast<std::size_t>(p * static_cast<double>(a.size()))] -
                       b[static_cast<std::size_t>(p * static_cast<double>(b.size()))]);
    }
    return s / k;
}

MarginalFidelity marginal_fidelity(const core::Image& exemplar, int size, int seeds) {
    MarginalFidelity f;
    core::AnalysisParams params;
    params.size = size;
    const auto t0 = std::chrono::steady_clock::now();
    auto analysed = core::analyze_texton(exemplar, params);
    if (!analysed) throw std::runtime_error(analysed.error().message);
    f.analysis_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const core::MarginalModel marginals = analysed.value().texton.marginals;
    auto tex = render::PreparedTexton::make(analysed.value().texton);
    if (!tex) throw std::runtime_error(tex.error().message);
    const core::GaussianModel model =
        core::estimate_gaussian_model(core::periodic_component(exemplar));
    render::CpuBackend cpu;
    // The noise's marginal is the process's: pooled over `seeds` windows of 1024 x 1024, so that
    // one window's sampling (its variance off by a few percent) does not pass for a model error.
    std::vector<std::vector<double>> pooled_g(static_cast<std::size_t>(marginals.channels)),
        pooled_e(pooled_g.size());
    for (int s = 1; s <= seeds; ++s) {
        render::NoiseRequest q;
        q.seed = static_cast<std::uint64_t>(s);
        q.width = q.height = 1024;
        q.x0 = 100000 * s;
        auto g = cpu.render(*tex.value(), q);
        q.marginals = render::Marginals::exemplar;
        auto e = cpu.render(*tex.value(), q);
        if (!g || !e) throw std::runtime_error("render failed");
        for (int i = 0; i < marginals.channels; ++i) {
            auto& pg = pooled_g[static_cast<std::size_t>(i)];
            auto& pe = pooled_e[static_cast<std::size_t>(i)];
            const auto yg = component(g.value(), marginals, i),
                       ye = component(e.value(), marginals, i);
            pg.insert(pg.end(), yg.begin(), yg.end());
            pe.insert(pe.end(), ye.begin(), ye.end());
        }
        // The spectrum on a window of the exemplar's size.
        const core::Image gw = window(g.value(), 0, 0, exemplar.width, exemplar.height);
        const core::Image ew = window(e.value(), 0, 0, exemplar.width, exemplar.height);
        f.rme_gaussian += spectrum_rme(model, gw) / seeds;
        f.rme_exemplar += spectrum_rme(model, ew) / seeds;
    }
    for (int i = 0; i < marginals.channels; ++i) {
        const auto y = component(exemplar, marginals, i);
        f.w1_gaussian +=
            wasserstein1(y, pooled_g[static_cast<std::size_t>(i)]) / marginals.channels;
        f.w1_exemplar +=
            wasserstein1(y, pooled_e[static_cast<std::size_t>(i)]) / marginals.channels;
    }
    return f;
}

} // namespace textond::test
