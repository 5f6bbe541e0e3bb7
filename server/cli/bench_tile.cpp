// `textond bench tile`: what one cold 256x256 PNG tile costs on one thread, render and encode,
// without the server: the baseline tests/load/load_test.sh sets the server's CPU per tile against.
#include "core/texton_analysis.h"
#include "render/cpu_backend.h"
#include "render/image_buffers.h"
#include "server/cli/args.h"
#include "server/cli/commands.h"
#include "server/io/image_io.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

namespace textond::cli {

namespace {
const char* kHelp =
    R"(usage: textond bench tile [--exemplar FILE] [--size R] [--count N] [--png-compression L]

Milliseconds per cold 256x256 tile on one thread, as `serve` makes it (CPU backend, 8-bit PNG,
distinct tiles of one texton): the render, the encode and their sum, medians over N tiles.
  --exemplar FILE        texture photo, analysed first  [../shared/data/exemplars/etr_sand01.png]
  --size R               texton support                                       [64]
  --count N              tiles                                                [200]
  --png-compression L    zlib level, as serve's flag                          [0]
)";

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}
} // namespace

int bench_tile_command(const Argv& argv) {
    auto args =
        parse_args(argv, {"--exemplar", "--size", "--count", "--png-compression"}, {"--help"});
    if (!args) return fail(2, args.error().message);
    const Args& a = args.value();
    if (a.flags.count("--help")) {
        std::printf("%s", kHelp);
        return 0;
    }
    auto size = a.get_int("--size", 64, 8, 256);
    auto count = a.get_int("--count", 200, 1, 100000);
    auto level = a.get_int("--png-compression", 0, 0, 9);
    if (!size || !count || !level) return fail(2, "bad --size, --count or --png-compression");
    const std::string path = a.get("--exemplar", "../shared/data/exemplars/etr_sand01.png");
    auto exemplar = io::decode_image_file(path);
    if (!exemplar) return fail(1, exemplar.error().message);
    core::AnalysisParams p;
    p.size = static_cast<int>(size.value());
    auto analysed = core::analyze_texton(exemplar.value(), p);
    if (!analysed) return fail(1, analysed.error().message);
    auto prepared = render::PreparedTexton::make(analysed.value().texton);
    if (!prepared) return fail(1, prepared.error().message);
    render::CpuBackend cpu(1);
    using Clock = std::chrono::steady_clock;
    std::vector<double> render_ms, encode_ms, total_ms;
    std::size_t bytes = 0;
    for (long long i = -5; i < count.value(); ++i) { // 5 warm-up tiles
        render::NoiseRequest q;
        q.x0 = 256 * i;
        q.y0 = 256 * 7;
        const auto t0 = Clock::now();
        auto image = cpu.render(*prepared.value(), q);
        if (!image) return fail(1, image.error().message);
        const auto t1 = Clock::now();
        auto png = io::encode_image_memory(image.value(), io::Encoding::png8, {},
                                           static_cast<int>(level.value()));
        if (!png) return fail(1, png.error().message);
        render::recycle_image(std::move(image.value()));
        const auto t2 = Clock::now();
        if (i < 0) continue;
        bytes = png.value().size();
        render_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        encode_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
        total_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
    }
    std::printf("| one thread, 256x256 PNG tile (r = %lld, %zu bytes) | ms |\n|---|---|\n",
                size.value(), bytes);
    std::printf("| render | %.3f |\n| encode | %.3f |\n| render + encode | %.3f |\n",
                median(render_ms), median(encode_ms), median(total_ms));
    return 0;
}

} // namespace textond::cli
