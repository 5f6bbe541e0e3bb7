#include "core/canonical_texton.h"
#include "core/gaussian_model.h"
#include "core/periodic_component.h"
#include "core/rme.h"
#include "core/texton_analysis.h"
#include "server/cli/analysis_options.h"
#include "server/cli/bench_analyze.h"
#include "server/cli/commands.h"
#include "server/io/image_io.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <vector>

namespace textond::cli {

namespace {
const char* kHelp =
    R"(usage: textond bench analyze [--exemplars DIR] [--repeat N] [--threads N] [--compare]
       textond bench render --help   (texton noise per backend against FFTW ADSN)
       textond bench tile --help     (one cold PNG tile on one thread: render, encode)

Times the texton analysis (r = 64, order 1, 50 iterations) on a 4096 x 4096 window of texton
noise cropped to 512² ... 4096² (time, ratio to 1024², peak memory, RME: past 1024 pixels a side
the analysis works on the centred 1024 x 1024 window), and on small exemplars by threads; then the
RME of the analysed texton against the cropped canonical texton for every exemplar in DIR.
  --exemplars DIR   texture photos                              [../shared/data/exemplars]
  --repeat N        runs per row; the table shows the median     [3]
  --threads N       threads for the multi-threaded column        [0 = all cores]
  --compare         beside each large size, the whole exemplar's analysis; then every photo of
                    DIR upscaled and tiled to 4096², windowed against whole (about 10 minutes)
)";

double median_ms(const core::Image& u, const core::AnalysisParams& p, int repeat) {
    auto run = analyse(u, p, repeat);
    if (!run) throw std::runtime_error(run.error().message);
    return run.value().ms;
}

// Analysis time on one thread and on all, by exemplar size (tiled past the exemplar's own).
void timing_table(const core::Image& sand, const core::Image& gravel, int repeat, int nthreads) {
    std::printf("Texton analysis time (median of %d runs; r = 64, order 1, 50 iterations)\n",
                repeat);
    std::printf("| exemplar size | channels | r  | iterations | ms (1 thread) | ms (%d threads) | "
                "speed-up |\n",
                nthreads);
    std::printf("|---------------|----------|----|------------|---------------|----------------|---"
                "-------|\n");
    struct Row {
        const core::Image* src;
        int w, h;
    };
    const Row rows[] = {{&sand, 128, 128}, {&sand, 256, 256},   {&sand, 512, 512},
                        {&sand, 768, 512}, {&gravel, 512, 512}, {&gravel, 768, 512}};
    for (const Row& row : rows) {
        const core::Image u = tiled(*row.src, row.w, row.h);
        core::AnalysisParams p;
        p.threads = 1;
        const double t1 = median_ms(u, p, repeat);
        p.threads = nthreads;
        const double tn = median_ms(u, p, repeat);
        std::printf("| %4dx%-8d | %8d | %2d | %10d | %13.1f | %14.1f | %7.2fx |\n", row.w, row.h,
                    u.channels, p.size, p.iterations, t1, tn, t1 / tn);
        std::fflush(stdout);
    }
}

// One exemplar's row: the analysed texton's RME (mean of 4 seeds) and the cropped canonical
// texton's, before and after colour correction.
Result<bool> rme_row(const std::filesystem::path& f, const core::Image& u, int nthreads) {
    double rc = 0, ru = 0;
    const int seeds = 4;
    for (int s = 0; s < seeds; ++s) {
        core::AnalysisParams p;
        p.seed = static_cast<std::uint64_t>(s);
        auto r = core::analyze_texton(u, p);
        if (!r) return r.error();
        rc += r.value().rme / seeds;
        ru += r.value().rme_uncorrected / seeds;
    }
    const core::GaussianModel model =
        core::estimate_gaussian_model(core::periodic_component(u, nthreads), nthreads);
    core::Texton crop = core::cropped_canonical_texton(model, 64, 1, nthreads);
    const double crop_rme = core::relative_model_error(model, crop.alpha, 1, 0, 0, nthreads);
    core::apply_colour_matrix(
        crop.alpha, core::colour_correction_matrix(model.covariance,
                                                   core::texton_noise_covariance(crop.alpha, 1)));
    const double crop_rme_c = core::relative_model_error(model, crop.alpha, 1, 0, 0, nthreads);
    std::printf("| %s | %.3f | %.3f | %.3f | %.3f |\n", f.filename().string().c_str(), rc, ru,
                crop_rme, crop_rme_c);
    std::fflush(stdout);
    return true;
}

std::vector<std::filesystem::path> exemplar_files(const std::filesystem::path& dir) {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(dir))
        if (e.path().extension() == ".png") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

int rme_table(const std::filesystem::path& dir, int nthreads) {
    std::printf("\nRME of the analysed texton (SOT) and of the cropped canonical texton, r = 64, "
                "order 1, 50 iterations, seeds 0-3\n");
    std::printf("| exemplar | SOT RME (corrected) | SOT RME (uncorrected) | canonical crop RME | "
                "canonical crop RME (corrected) |\n");
    std::printf("|---|---|---|---|---|\n");
    for (const auto& f : exemplar_files(dir)) {
        auto u = io::decode_image_file(f.string());
        if (!u) continue;
        if (auto row = rme_row(f, u.value(), nthreads); !row) return fail(1, row.error().message);
    }
    return 0;
}
} // namespace

int bench_command(const Argv& argv) {
    if (!argv.empty() && argv[0] == "render")
        return bench_render_command(Argv(argv.begin() + 1, argv.end()));
    if (!argv.empty() && argv[0] == "tile")
        return bench_tile_command(Argv(argv.begin() + 1, argv.end()));
    auto args = parse_args(argv, {"--exemplars", "--repeat", "--threads"}, {"--help", "--compare"});
    if (!args) return fail(2, args.error().message);
    const Args& a = args.value();
    if (a.flags.count("--help") || a.positional.empty()) {
        std::printf("%s", kHelp);
        return a.flags.count("--help") ? 0 : 2;
    }
    if (a.positional[0] != "analyze") return fail(2, "unknown benchmark '" + a.positional[0] + "'");
    auto repeat = a.get_int("--repeat", 3, 1, 100);
    auto threads = a.get_int("--threads", 0, 0, 256);
    if (!repeat || !threads) return fail(2, "bad --repeat or --threads");
    const std::filesystem::path dir = a.get("--exemplars", "../shared/data/exemplars");

    auto sand = io::decode_image_file((dir / "etr_sand01.png").string());
    auto gravel = io::decode_image_file((dir / "skimage_gravel.png").string());
    if (!sand || !gravel) return fail(1, "exemplars not found in " + dir.string());

    const int nthreads = core::resolve_threads(static_cast<int>(threads.value()));
    const bool compare = a.flags.count("--compare") > 0;
    if (auto t = scaling_table(sand.value(), static_cast<int>(repeat.value()), compare); !t)
        return fail(1, t.error().message);
    std::printf("\n");
    timing_table(sand.value(), gravel.value(), static_cast<int>(repeat.value()), nthreads);
    if (compare)
        if (auto t = photo_table(exemplar_files(dir)); !t) return fail(1, t.error().message);
    return rme_table(dir, nthreads);
}

} // namespace textond::cli
