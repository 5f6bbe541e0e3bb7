#include "core/spectral_synthesis.h"
#include "core/texton_analysis.h"
#include "core/texture_mix.h"
#include "render/backend_factory.h"
#include "render/cpu_backend.h"
#include "render/gl/gl_backend.h"
#include "render/prepared_mix.h"
#include "render/prepared_splat.h"
#include "render/renderer.h"
#include "render/settled.h"
#include "render/surface_eval.h"
#include "server/cli/args.h"
#include "server/cli/commands.h"
#include "server/io/image_io.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace textond::cli {

namespace {
const char* kHelp =
    R"(usage: textond bench render [--exemplars DIR] [--repeat N] [--backends LIST] [--threads N]

Milliseconds per frame of texton noise (MNI 30, level 0) for each backend at 256x256, 1024x1024,
1920x1080 and 3840x2160, with textons of r = 64 and r = 256 (the paper's Table 1), next to an
FFTW ADSN of the same size measured in the same run (ratio = ADSN ms / backend ms); for OpenGL
also the GPU time of the dispatches alone (timer queries), where the rest is readback and
conversion, and (OpenGL) the same frame read back as 8-bit RGB bytes, rounded on the GPU as the
PNG encoder rounds and handed on as the bytes a PNG tile is encoded from; on a GPU, 4K frames at 1, 2 and 4 times the pass size, each pass's GPU ms. Then 64 tiles of 256x256 as 8-bit: one call each, and as one batch (OpenGL: one
upload, one dispatch and one readback; the CPU renders them one after another). Also one
256x256 tile at every level 0..5 (exact box filtering), 6 and 8 (limit model), 24 and -2, with
its ratio to level 0, one 1024x1024 frame at interpolation orders 0, 1, 3, and (CPU,
one thread) a texture-mix tile, splat tiles of 2, 4 and 8 layers and 65536 surface-noise points
against a plain tile. Textons are analysed from mypaint_HR_Cork.png (512x512 colour).
  --exemplars DIR   texture photos                              [../shared/data/exemplars]
  --repeat N        frames per row; the table shows the median    [5]
  --backends LIST   comma-separated: cpu, osmesa, egl (skipped when absent)   [cpu,egl]
  --threads N       CPU backend and FFTW threads, 0 = all cores   [0]
  --max-side N      skip frame sizes wider than N (OSMesa is slow) [3840]
  --gl-points K     OpenGL's point kernel: shared (drawn by each workgroup), listed (on the
                    host), or auto (shared on a GPU, listed on llvmpipe); the same bits  [auto]
)";

template <class F> double median_ms(int repeat, F&& f) {
    std::vector<double> ms;
    for (int i = 0; i < repeat; ++i) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
    }
    std::sort(ms.begin(), ms.end());
    return ms[ms.size() / 2];
}

using Prepared = std::shared_ptr<const render::PreparedTexton>;

// What every table reads: the options, the backends and the cork texton of r = 64.
struct Bench {
    std::filesystem::path dir;
    core::Image sand;
    int repeat = 5, threads = 1, max_side = 3840;
    std::vector<std::shared_ptr<render::Backend>> backends;
    Prepared r64;
};

Result<Prepared> prepare(const core::Image& exemplar, int size, int order = 1) {
    core::AnalysisParams p;
    p.size = size;
    p.order = order;
    auto analysed = core::analyze_texton(exemplar, p);
    if (!analysed) return analysed.error();
    auto prepared = render::PreparedTexton::make(analysed.value().texton);
    if (!prepared) return prepared.error();
    return Prepared(prepared.value());
}

// Backends that cannot start here are named and skipped; `points` sets the GL point kernel.
Result<bool> open_backends(const std::string& names, const std::string& points, Bench& b) {
    if (points != "auto" && points != "shared" && points != "listed")
        return make_error(ErrorCode::invalid_argument, "--gl-points is auto, shared or listed");
    std::stringstream list(names);
    for (std::string name; std::getline(list, name, ',');) {
        auto kind = render::parse_backend_kind(name);
        if (!kind) return kind.error();
        render::BackendOptions bo;
        bo.threads = b.threads;
        auto made = render::make_backend(kind.value(), bo);
        if (!made) {
            std::printf("(%s skipped: %s)\n", name.c_str(), made.error().message.c_str());
            continue;
        }
        if (auto gl = std::dynamic_pointer_cast<render::GlBackend>(made.value().backend);
            gl && points != "auto")
            gl->set_point_kernel(points == "shared" ? render::GlBackend::PointKernel::shared
                                                    : render::GlBackend::PointKernel::host_listed);
        std::printf("%s: %s\n", name.c_str(), made.value().backend->renderer().c_str());
        b.backends.push_back(made.value().backend);
    }
    return true;
}

struct Size {
    int w, h;
    const char* label;
};

// One row of the frame table: float frames (and their GPU time), then 8-bit frames on OpenGL.
Result<bool> frame_row(const Bench& b, render::Backend& backend, const render::PreparedTexton& tex,
                       int r, const Size& s, double adsn) {
    render::NoiseRequest q;
    q.width = s.w;
    q.height = s.h;
    q.seed = 1;
    auto warm = backend.render(tex, q); // first use builds tables and uploads textures
    if (!warm) return warm.error();
    // A GPU is timed at the clock it serves at: frames until the times settle (render/settled.h),
    // as auto's calibration does. Its idle clock had made a 4K frame 25 ms where the same GPU's
    // HD frames, timed after load, gave 4.3 ms a 4K's pixels.
    const auto* gl = dynamic_cast<const render::GlBackend*>(&backend);
    if (gl && !gl->software()) {
        auto settled = render::settled_ms(400, 3000, [&]() -> std::optional<Error> {
            ++q.seed;
            auto img = backend.render(tex, q);
            if (!img) return img.error();
            return std::nullopt;
        });
        if (!settled) return settled.error();
    }
    std::vector<double> gpu;
    const double ms = median_ms(b.repeat, [&] {
        ++q.seed;
        render::RenderStats stats;
        auto img = backend.render(tex, q, &stats);
        gpu.push_back(stats.gpu_ms);
    });
    std::sort(gpu.begin(), gpu.end());
    const double gpu_ms = gpu[gpu.size() / 2];
    char gpu_text[32] = "-", u8_text[32] = "-";
    if (gpu_ms >= 0) {
        std::snprintf(gpu_text, sizeof gpu_text, "%.2f", gpu_ms);
        q.precision = render::Precision::u8;
        q.bytes = true; // as a PNG tile is served: the bytes, no floats
        const double ms8 = median_ms(b.repeat, [&] {
            ++q.seed;
            auto img = backend.render(tex, q);
        });
        std::snprintf(u8_text, sizeof u8_text, "%.2f", ms8);
    }
    std::printf("| %s | %d | %s | %.2f | %s | %s | %.2f | %.2fx |\n", backend.name().c_str(), r,
                s.label, ms, gpu_text, u8_text, adsn, adsn / ms);
    std::fflush(stdout);
    return true;
}

// The 4K frame by pass size (output words a pass; the default first), with each pass's GPU ms.
void passes_by_size(const Bench& b, render::GlBackend& gl) {
    const std::size_t standard = gl.pass_words();
    for (auto precision : {render::Precision::f32, render::Precision::u8})
        for (std::size_t words : {standard, standard * 2, standard * 4}) {
            gl.set_pass_words(words);
            render::NoiseRequest q;
            q.width = 3840;
            q.height = 2160;
            q.precision = precision;
            q.bytes = precision == render::Precision::u8;
            std::vector<std::pair<double, std::vector<double>>> gpu;
            const double ms = median_ms(b.repeat, [&] {
                ++q.seed;
                render::RenderStats stats;
                auto img = gl.render(*b.r64, q, &stats);
                gpu.emplace_back(stats.gpu_ms, gl.last_pass_ms());
            });
            std::sort(gpu.begin(), gpu.end());
            const auto& [total, each] = gpu[gpu.size() / 2];
            std::string list;
            for (double p : each)
                list += (list.empty() ? "" : " ") + std::to_string(p).substr(0, 5);
            std::printf("| %s | %s | 2^%d | %zu | %.2f | %.2f | %s |\n", gl.name().c_str(),
                        precision == render::Precision::u8 ? "8-bit" : "float",
                        static_cast<int>(std::log2(static_cast<double>(words))), each.size(), ms,
                        total, list.c_str());
            std::fflush(stdout);
        }
    gl.set_pass_words(0);
}

// One pass a frame (8-bit, 4 times the default pass): GPU ns a pixel by the frame's shape. The
// same ns for every shape means a 4K/HD ratio off 4x is the GPU's clock, not the kernel.
void frames_by_shape(const Bench& b, render::GlBackend& gl) {
    std::printf(
        "\nOne-pass 8-bit frames by shape (r = 64; GPU ms: min and median of %d)\n"
        "| backend | frame | GPU ms min | median | ns/pixel (min) |\n|---|---|---|---|---|\n",
        b.repeat);
    gl.set_pass_words(gl.pass_words() * 4);
    const Size shapes[] = {{1920, 1080, "1920x1080"}, {2048, 1080, "2048x1080"},
                           {1920, 2160, "1920x2160"}, {3840, 1080, "3840x1080"},
                           {2048, 2048, "2048x2048"}, {3840, 2160, "3840x2160"}};
    for (const Size& s : shapes) {
        render::NoiseRequest q;
        q.width = s.w;
        q.height = s.h;
        q.precision = render::Precision::u8;
        q.bytes = true;
        std::vector<double> gpu;
        median_ms(b.repeat, [&] {
            ++q.seed;
            render::RenderStats stats;
            auto img = gl.render(*b.r64, q, &stats);
            gpu.push_back(stats.gpu_ms);
        });
        std::sort(gpu.begin(), gpu.end());
        std::printf("| %s | %s | %.2f | %.2f | %.3f |\n", gl.name().c_str(), s.label, gpu.front(),
                    gpu[gpu.size() / 2], gpu.front() * 1e6 / (double(s.w) * s.h));
        std::fflush(stdout);
    }
    gl.set_pass_words(0);
}

// OpenGL on a GPU: what a large frame's GPU time is made of (passes, then the frame's shape).
void passes_table(const Bench& b) {
    if (b.max_side < 3840) return;
    for (const auto& backend : b.backends) {
        auto gl = std::dynamic_pointer_cast<render::GlBackend>(backend);
        if (!gl || gl->software()) continue;
        std::printf("\n4K 3840x2160 frames by pass size (r = 64, MNI 30, level 0, median of %d)"
                    "\n| backend | output | words a pass | passes | ms/frame | GPU ms | GPU ms "
                    "of each pass |\n|---|---|---|---|---|---|---|\n",
                    b.repeat);
        passes_by_size(b, *gl);
        frames_by_shape(b, *gl);
    }
}

// The paper's Table 1: frames of r = 64 and r = 256 textons against FFTW's ADSN; keeps r = 64.
Result<bool> frames_table(Bench& b) {
    const Size sizes[] = {{256, 256, "256x256"},
                          {1024, 1024, "1024x1024"},
                          {1920, 1080, "HD 1920x1080"},
                          {3840, 2160, "4K 3840x2160"}};
    std::printf("\nTexton noise, MNI 30, level 0, median of %d frames; ADSN = FFTW spectral "
                "synthesis of the same texton and size (%d threads)\n",
                b.repeat, b.threads);
    std::printf(
        "| backend | r | frame | ms/frame | GPU ms | ms as 8-bit | ADSN ms | ADSN / backend |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (int r : {64, 256}) {
        auto prepared = prepare(b.sand, r);
        if (!prepared) return prepared.error();
        if (r == 64) b.r64 = prepared.value();
        const auto& tex = *prepared.value();
        for (const Size& s : sizes) {
            if (s.w > b.max_side) continue;
            const double adsn = median_ms(std::max(1, b.repeat / 2), [&] {
                core::synthesize_from_texton(tex.texton(), core::SpectralMethod::adsn, s.w, s.h, 1,
                                             b.threads);
            });
            for (const auto& backend : b.backends)
                if (auto row = frame_row(b, *backend, tex, r, s, adsn); !row) return row;
        }
        std::printf("| | | | | | | | |\n");
    }
    return true;
}

// Milliseconds for 64 cold tiles, and the GPU's share (negative: not measured).
std::pair<double, double> tiles_ms(const Bench& b, render::Backend& backend, bool batch) {
    std::vector<render::NoiseRequest> qs(64);
    std::uint64_t seed = 1;
    std::vector<double> gpu;
    const double ms = median_ms(b.repeat, [&] {
        for (std::size_t t = 0; t < qs.size(); ++t) {
            qs[t].x0 = 256 * static_cast<std::int64_t>(t % 8);
            qs[t].y0 = 256 * static_cast<std::int64_t>(t / 8);
            qs[t].seed = ++seed;
            qs[t].precision = render::Precision::u8;
            qs[t].bytes = true;
        }
        double sum = 0;
        if (batch) {
            render::RenderStats stats;
            auto imgs = backend.render_many(*b.r64, qs, &stats);
            sum = stats.gpu_ms;
        } else {
            for (const auto& q : qs) {
                render::RenderStats stats;
                auto img = backend.render(*b.r64, q, &stats);
                sum += stats.gpu_ms;
            }
        }
        gpu.push_back(sum);
    });
    std::sort(gpu.begin(), gpu.end());
    return {ms, gpu[gpu.size() / 2]};
}

// What a tile server does: 64 cold 256x256 8-bit tiles of the r = 64 texton, one call each,
// then as one batch (what concurrent requests become on a GL backend).
void tiles_table(const Bench& b) {
    std::printf("\n64 tiles of 256x256 as 8-bit (r = 64, MNI 30, level 0)\n");
    std::printf(
        "| backend | calls | ms for 64 | ms/tile | GPU ms for 64 |\n|---|---|---|---|---|\n");
    for (const auto& backend : b.backends)
        for (bool batch : {false, true}) {
            if (batch && backend->name() == "cpu") continue; // no batches: the same calls
            const auto [ms, gpu] = tiles_ms(b, *backend, batch);
            char gpu_text[32] = "-";
            if (gpu >= 0) std::snprintf(gpu_text, sizeof gpu_text, "%.2f", gpu);
            std::printf("| %s | %s | %.2f | %.3f | %s |\n", backend->name().c_str(),
                        batch ? "one batch" : "64", ms, ms / 64, gpu_text);
        }
}

Result<bool> levels_table(const Bench& b) {
    std::printf("\nOne 256x256 tile by level (r = 64, MNI 30; levels >= 6 use the limit model)\n");
    std::printf("| backend | level | ms/tile | ratio to level 0 |\n|---|---|---|---|\n");
    for (const auto& backend : b.backends) {
        double base = 0.0;
        // Every exact level of this texton (1..5), two limit-model levels and a magnified one.
        for (int level : {0, 1, 2, 3, 4, 5, 6, 8, 24, -2}) {
            render::NoiseRequest q;
            q.level = level;
            q.x0 = 12345;
            q.y0 = -777;
            auto warm = backend->render(*b.r64, q);
            if (!warm) return warm.error();
            const double ms = median_ms(b.repeat, [&] {
                ++q.seed;
                auto img = backend->render(*b.r64, q);
            });
            if (level == 0) base = ms;
            std::printf("| %s | %d | %.2f | %.2fx |\n", backend->name().c_str(), level, ms,
                        ms / base);
        }
    }
    return true;
}

Result<bool> orders_table(const Bench& b) {
    const int side = std::min(1024, b.max_side);
    std::printf("\nOne %dx%d frame by interpolation order (r = 64, MNI 30, level 0)\n", side, side);
    std::printf("| backend | order | ms/frame | ratio to order 1 |\n|---|---|---|---|\n");
    Prepared by_order[4] = {nullptr, b.r64, nullptr, nullptr};
    for (int order : {0, 3}) {
        auto prepared = prepare(b.sand, 64, order);
        if (!prepared) return prepared.error();
        by_order[order] = prepared.value();
    }
    for (const auto& backend : b.backends) {
        double base = 0.0;
        for (int order : {1, 0, 3}) {
            render::NoiseRequest q;
            q.width = q.height = side;
            auto warm = backend->render(*by_order[order], q);
            if (!warm) return warm.error();
            const double ms = median_ms(b.repeat, [&] {
                ++q.seed;
                auto img = backend->render(*by_order[order], q);
            });
            if (order == 1) base = ms;
            std::printf("| %s | %d | %.2f | %.2fx |\n", backend->name().c_str(), order, ms,
                        ms / base);
        }
    }
    return true;
}

// A mix tile with 21 levels across it, and the time to build the levels.
Result<bool> mix_rows(const Bench& b, render::CpuBackend& cpu1, render::NoiseRequest tile,
                      double plain) {
    auto other = io::decode_image_file((b.dir / "etr_pebbles04.png").string());
    if (!other)
        return make_error(ErrorCode::io, "etr_pebbles04.png not found in " + b.dir.string());
    core::AnalysisParams p;
    p.size = 64;
    p.threads = b.threads;
    const auto t0 = std::chrono::steady_clock::now();
    auto pair = core::common_models(b.sand, other.value(), true, b.threads, 2 * p.size);
    if (!pair) return pair.error();
    auto levels = core::mix_levels(pair.value(), p, core::kDefaultMixLevels);
    if (!levels) return levels.error();
    const double build =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    core::MixField f;
    f.x0 = -128;
    f.width = 256;
    auto mix = render::PreparedMix::make(levels.value().levels, f);
    if (!mix) return mix.error();
    auto warm = cpu1.render_mix(*mix.value(), tile);
    const double ms = median_ms(b.repeat, [&] {
        ++tile.seed;
        auto img = cpu1.render_mix(*mix.value(), tile);
    });
    std::printf("| mix tile, 21 levels across it | %.2f | %.2fx |\n", ms, ms / plain);
    std::printf("| building the 21 levels (%d threads) | %.0f | %.0fx |\n", b.threads, build,
                build / plain);
    return true;
}

// Splat tiles of K layers of the r = 64 texton (the cost of a layer does not depend on which):
// every layer shown (even weights everywhere), and four layers of which one shows (the others'
// weights are 0 over the tile, so they are not rendered). Through the Renderer, one CPU thread.
Result<bool> splat_rows(const Bench& b, render::NoiseRequest tile, double plain) {
    render::BackendOptions o;
    o.threads = 1;
    auto r = render::Renderer::make(render::BackendKind::cpu, o);
    if (!r) return r.error();
    auto row = [&](int k, bool all, const char* what) -> Result<bool> {
        core::SplatWeights w;
        w.image.weights = core::Image(1, 1, k, 0.0f);
        for (int l = 0; l < (all ? k : 1); ++l)
            w.image.weights.data[static_cast<std::size_t>(l)] = 1;
        auto s = render::PreparedSplat::make(
            std::vector<Prepared>(static_cast<std::size_t>(k), b.r64), w);
        if (!s) return s.error();
        const double ms = median_ms(b.repeat, [&] {
            ++tile.seed;
            auto img = r.value()->splat(*s.value(), tile, render::Renderer::Work::tile);
        });
        std::printf("| splat tile, %d layers, %s | %.2f | %.2fx |\n", k, what, ms, ms / plain);
        return true;
    };
    for (int k : {2, 4, 8})
        if (auto done = row(k, true, "all shown"); !done) return done;
    return row(4, false, "one shown");
}

// Surface noise at as many points on a sphere as the tile has pixels.
void surface_rows(const Bench& b, double plain) {
    const int n = 65536;
    std::vector<float> pts(3 * n), nrm(3 * n);
    for (int i = 0; i < n; ++i) {
        const double z = 1 - 2 * (i + 0.5) / n, rad = std::sqrt(1 - z * z), phi = i * 2.39996;
        const float d[3] = {static_cast<float>(rad * std::cos(phi)),
                            static_cast<float>(rad * std::sin(phi)), static_cast<float>(z)};
        for (std::size_t k = 0; k < 3; ++k) {
            pts[3 * static_cast<std::size_t>(i) + k] = 500 * d[k];
            nrm[3 * static_cast<std::size_t>(i) + k] = d[k];
        }
    }
    for (double mni : {30.0, 60.0}) {
        render::SurfaceRequest sr;
        sr.mni = mni;
        const double ms = median_ms(b.repeat, [&] {
            ++sr.seed;
            auto c = render::evaluate_surface(b.r64->texton(), sr, pts, nrm, 1);
        });
        std::printf("| surface noise, 65536 points, MNI %.0f | %.2f | %.2fx |\n", mni, ms,
                    ms / plain);
    }
}

// Texture mixing and surface noise (CPU, one thread) against a plain 256x256 level-0 tile of
// the same r = 64 texton, measured here too.
Result<bool> cpu_table(const Bench& b) {
    render::CpuBackend cpu1(1);
    render::NoiseRequest tile;
    tile.x0 = -128;
    const double plain = median_ms(b.repeat, [&] {
        ++tile.seed;
        auto img = cpu1.render(*b.r64, tile);
    });
    std::printf("\nCPU, one thread: a 256x256 tile of the r = 64 texton (%.2f ms) against\n",
                plain);
    std::printf("| what | ms | ratio to the plain tile |\n|---|---|---|\n");
    if (auto rows = mix_rows(b, cpu1, tile, plain); !rows) return rows;
    if (auto rows = splat_rows(b, tile, plain); !rows) return rows;
    surface_rows(b, plain);
    return true;
}

Result<bool> run_tables(Bench& b) {
    if (auto r = frames_table(b); !r) return r;
    passes_table(b);
    tiles_table(b);
    if (auto r = levels_table(b); !r) return r;
    if (auto r = orders_table(b); !r) return r;
    return cpu_table(b);
}

} // namespace

int bench_render_command(const Argv& argv) {
    auto args = parse_args(
        argv, {"--exemplars", "--repeat", "--backends", "--threads", "--max-side", "--gl-points"},
        {"--help"});
    if (!args) return fail(2, args.error().message);
    const Args& a = args.value();
    if (a.flags.count("--help")) {
        std::printf("%s", kHelp);
        return 0;
    }
    auto repeat = a.get_int("--repeat", 5, 1, 1000);
    auto threads = a.get_int("--threads", 0, 0, 256);
    auto max_side = a.get_int("--max-side", 3840, 1, 16384);
    if (!repeat || !threads || !max_side) return fail(2, "bad --repeat, --threads or --max-side");
    Bench b;
    b.dir = a.get("--exemplars", "../shared/data/exemplars");
    auto sand = io::decode_image_file((b.dir / "mypaint_HR_Cork.png").string());
    if (!sand) return fail(1, "exemplars not found in " + b.dir.string());
    b.sand = std::move(sand.value());
    b.repeat = static_cast<int>(repeat.value());
    b.max_side = static_cast<int>(max_side.value());
    b.threads = core::resolve_threads(static_cast<int>(threads.value()));
    if (auto opened =
            open_backends(a.get("--backends", "cpu,egl"), a.get("--gl-points", "auto"), b);
        !opened)
        return fail(2, opened.error().message);
    if (auto ran = run_tables(b); !ran) return fail(1, ran.error().message);
    return 0;
}

} // namespace textond::cli
