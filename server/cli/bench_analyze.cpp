// bench analyze, by exemplar size: the analysis's time, its peak memory and its RME with the
// working window (core/working_window.h), and with --compare the whole exemplar's analysis
// beside it, on texton noise and on every shared photo upscaled and tiled to 4096 x 4096.
#include "server/cli/bench_analyze.h"

#include "core/gaussian_model.h"
#include "core/periodic_component.h"
#include "core/rme.h"
#include "core/texton_analysis.h"
#include "render/backend_factory.h"
#include "render/prepared_texton.h"
#include "server/io/image_io.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace textond::cli {

namespace {

constexpr int kLargest = 4096;
const core::AnalysisParams windowed{};
const core::AnalysisParams whole_exemplar = [] {
    core::AnalysisParams p;
    p.working_side = 0;
    return p;
}();

// Peak resident memory since the last reset, over what was resident then (Linux: writing 5 to
// clear_refs resets VmHWM to VmRSS).
long status_kb(const char* field) {
    std::ifstream f("/proc/self/status");
    for (std::string line; std::getline(f, line);)
        if (line.rfind(field, 0) == 0) return std::stol(line.substr(std::string(field).size()));
    return 0;
}
void reset_peak() {
    std::ofstream("/proc/self/clear_refs") << "5";
}

// The RME of `t` against the whole exemplar's model: how well a windowed texton summarises all
// of it.
double rme_against_whole(const core::Image& u, const core::Texton& t) {
    const core::GaussianModel model =
        core::estimate_gaussian_model(core::periodic_component(u, 0), 0);
    return core::relative_model_error(model, t.alpha, t.order, 0, 0, 0);
}

Result<core::Image> noise_window(const core::Image& exemplar) {
    core::AnalysisParams p;
    auto analysed = core::analyze_texton(exemplar, p);
    if (!analysed) return analysed.error();
    auto prepared = render::PreparedTexton::make(analysed.value().texton);
    if (!prepared) return prepared.error();
    auto backend = render::make_backend(render::BackendKind::cpu);
    if (!backend) return backend.error();
    render::NoiseRequest q;
    q.width = q.height = kLargest;
    q.seed = 1;
    return backend.value().backend->render(*prepared.value(), q);
}

// Bilinear, pixel centres aligned.
core::Image upscaled(const core::Image& src, int w, int h) {
    core::Image out(w, h, src.channels);
    for (int c = 0; c < src.channels; ++c)
        for (int y = 0; y < h; ++y) {
            const double fy = std::clamp((y + 0.5) * src.height / h - 0.5, 0.0, src.height - 1.0);
            const int y0 = static_cast<int>(fy), y1 = std::min(y0 + 1, src.height - 1);
            const double ty = fy - y0;
            for (int x = 0; x < w; ++x) {
                const double fx = std::clamp((x + 0.5) * src.width / w - 0.5, 0.0, src.width - 1.0);
                const int x0 = static_cast<int>(fx), x1 = std::min(x0 + 1, src.width - 1);
                const double tx = fx - x0;
                const double top = src.at(c, x0, y0) * (1 - tx) + src.at(c, x1, y0) * tx;
                const double bottom = src.at(c, x0, y1) * (1 - tx) + src.at(c, x1, y1) * tx;
                out.at(c, x, y) = static_cast<float>(top * (1 - ty) + bottom * ty);
            }
        }
    return out;
}

} // namespace

core::Image tiled(const core::Image& src, int w, int h) {
    core::Image out(w, h, src.channels);
    for (int c = 0; c < src.channels; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) out.at(c, x, y) = src.at(c, x % src.width, y % src.height);
    return out;
}

Result<AnalysisRun> analyse(const core::Image& u, const core::AnalysisParams& p, int repeat) {
    std::vector<double> ms, verdict;
    AnalysisRun run;
    reset_peak();
    const long base_kb = status_kb("VmRSS:");
    for (int i = 0; i < repeat; ++i) {
        const auto t0 = std::chrono::steady_clock::now();
        auto r = core::analyze_texton(u, p);
        ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
        if (!r) return r.error();
        verdict.push_back(r.value().timings.shape_ms);
        run.rme = r.value().rme;
        run.texton = std::move(r.value().texton);
    }
    run.peak_mib = (status_kb("VmHWM:") - base_kb) / 1024;
    std::sort(ms.begin(), ms.end());
    std::sort(verdict.begin(), verdict.end());
    run.ms = ms[ms.size() / 2];
    run.verdict_ms = verdict[verdict.size() / 2];
    return run;
}

Result<bool> scaling_table(const core::Image& sand, int repeat, bool compare) {
    auto noise = noise_window(sand);
    if (!noise) return noise.error();
    std::printf("Analysis by exemplar size: a %dx%d window of sand's texton noise, centre crops; "
                "r 64, order 1, 50 iterations, all cores; median of %d runs; peak: resident "
                "memory over the analysis's start\n",
                kLargest, kLargest, repeat);
    std::printf("| exemplar | analysis (ms) | / 1024² | verdict (ms) | peak (MiB) | RME |%s\n",
                compare ? " whole: analysis (ms) | whole: peak (MiB) | whole: RME | RME - whole |"
                          " windowed texton's RME on the whole model |"
                        : "");
    std::printf("|---|---|---|---|---|---|%s\n", compare ? "---|---|---|---|---|" : "");
    double ms1024 = 0;
    for (int side = 512; side <= kLargest; side *= 2) {
        const core::Image crop = core::working_window(noise.value(), side);
        const core::Image& u = crop.empty() ? noise.value() : crop;
        auto w = analyse(u, windowed, repeat);
        if (!w) return w.error();
        if (side == 1024) ms1024 = w.value().ms;
        std::printf("| %d² | %.0f | %s | %.0f | %ld | %.4f |", side, w.value().ms,
                    ms1024 > 0 ? (std::to_string(w.value().ms / ms1024).substr(0, 4) + "x").c_str()
                               : "-",
                    w.value().verdict_ms, w.value().peak_mib, w.value().rme);
        if (compare) {
            auto whole = analyse(u, whole_exemplar, 1);
            if (!whole) return whole.error();
            std::printf(" %.0f | %ld | %.4f | %+.4f | %.4f |", whole.value().ms,
                        whole.value().peak_mib, whole.value().rme,
                        w.value().rme - whole.value().rme, rme_against_whole(u, w.value().texton));
        }
        std::printf("\n");
        std::fflush(stdout);
    }
    return true;
}

Result<bool> photo_table(const std::vector<std::filesystem::path>& files) {
    std::printf("\nEvery shared photo made %dx%d (upscaled bilinearly, or tiled): RME of the "
                "windowed analysis against the whole exemplar's (r 64, order 1, 50 iterations)\n",
                kLargest, kLargest);
    std::printf("| exemplar | made | windowed (ms) | whole (ms) | windowed RME | whole RME | "
                "RME - whole | windowed texton's RME on the whole model |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const auto& f : files) {
        auto src = io::decode_image_file(f.string());
        if (!src) continue;
        for (const bool tile : {false, true}) {
            const core::Image u = tile ? tiled(src.value(), kLargest, kLargest)
                                       : upscaled(src.value(), kLargest, kLargest);
            auto w = analyse(u, windowed, 1);
            auto whole = w ? analyse(u, whole_exemplar, 1) : w;
            if (!whole) return whole.error();
            std::printf("| %s | %s | %.0f | %.0f | %.4f | %.4f | %+.4f | %.4f |\n",
                        f.filename().string().c_str(), tile ? "tiled" : "upscaled", w.value().ms,
                        whole.value().ms, w.value().rme, whole.value().rme,
                        w.value().rme - whole.value().rme, rme_against_whole(u, w.value().texton));
            std::fflush(stdout);
        }
    }
    return true;
}

} // namespace textond::cli
