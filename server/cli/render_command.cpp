#include "render/backend_factory.h"
#include "server/cli/analysis_options.h"
#include "server/cli/commands.h"
#include "server/cli/texton_input.h"
#include "server/cli/window_options.h"
#include "server/io/image_io.h"

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdint>
#include <cstdio>

namespace textond::cli {

namespace {
const char* kHelp = R"(usage: textond render INPUT [options] -o OUT.png|OUT.exr

Evaluates a window of the texton noise of INPUT (render/NOISE_SPEC.md): a texton file written by
`textond analyze`, or an exemplar that is analysed first (analysis options below). Prints a JSON
summary (backend, timing) on stdout.
  --x X, --y Y      window origin in output pixels of the level, signed 64-bit   [0]
  --w W, --h H      window size in pixels, 1..16384                             [512]
  --lod K           level -4..24: 2^K texels per output pixel (K < 0 magnifies)  [0]
  --seed N          noise seed (unsigned 64-bit)                                [0]
  --mni M           mean number of impacts per pixel, 1..200                    [30]
  --period P        tileable mode: the noise repeats every P cells (P x cell side texels)
  --marginals M     gaussian | exemplar: map the noise onto the exemplar's colour
                    marginals (core/README.md "Marginals")                              [gaussian]
  --backend B       auto | cpu | osmesa | egl                                   [auto]
  --render-threads N  CPU backend threads, 0 = all cores                        [0]
  --png16           16-bit PNG instead of 8-bit
  -o, --output FILE .png (clamped to [0, 1]) or .exr (float32)
)";
} // namespace

int render_command(const Argv& argv) {
    auto parsed = parse_input_command(argv, "render", kHelp, "INPUT", true,
                                      {"--output", "--x", "--y", "--w", "--h", "--lod", "--mni",
                                       "--period", "--backend", "--render-threads", "--marginals"},
                                      {"--png16"});
    if (auto* code = std::get_if<int>(&parsed)) return *code;
    const Args& a = std::get<Args>(parsed);
    auto window = window_from(a, 512, 512);
    if (!window) return fail(2, window.error().message);
    render::NoiseRequest q = window.value();
    auto seed = a.get_u64("--seed", 0);
    if (!seed) return fail(2, seed.error().message);
    auto period = a.get_int("--period", 0, 0, 1 << 20);
    if (!period) return fail(2, period.error().message);
    q.seed = seed.value();
    q.period = {period.value(), period.value()};
    auto kind = render::parse_backend_kind(a.get("--backend", "auto"));
    if (!kind) return fail(2, kind.error().message);
    auto threads = a.get_int("--render-threads", 0, 0, 256);
    if (!threads) return fail(2, threads.error().message);
    auto encoding = output_encoding_from(a);
    if (!encoding) return fail(2, encoding.error().message);
    const io::Encoding enc = encoding.value();

    auto texton = load_or_analyze(a.positional[0], a);
    if (!texton) return fail(1, texton.error().message);
    auto prepared = render::PreparedTexton::make(std::move(texton.value()));
    if (!prepared) return fail(1, prepared.error().message);
    if (auto err = prepared.value()->check(q)) return fail(2, err->message);
    render::BackendOptions bo;
    bo.threads = static_cast<int>(threads.value());
    auto choice = render::make_backend(kind.value(), bo);
    if (!choice) return fail(1, choice.error().message);
    spdlog::info("backend: {}", choice.value().reason);

    const auto t0 = std::chrono::steady_clock::now();
    auto image = choice.value().backend->render(*prepared.value(), q);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (!image) return fail(1, image.error().message);
    auto written = io::encode_image_file(image.value(), a.get("--output"), enc,
                                         {{"textond:noise", render::kNoiseVersion}});
    if (!written) return fail(1, written.error().message);
    nlohmann::json j = {{"backend", choice.value().backend->name()},
                        {"renderer", choice.value().backend->renderer()},
                        {"noise", render::kNoiseVersion},
                        {"width", q.width},
                        {"height", q.height},
                        {"level", q.level},
                        {"limit_model", q.level >= prepared.value()->limit_level()},
                        {"render_ms", ms},
                        {"output", a.get("--output")}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
}

} // namespace textond::cli
