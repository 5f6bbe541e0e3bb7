// Tile formats for web pipelines: 256x256 tiles of texton noise from three shared
// exemplars (colour and grey), each encoded as the server encodes it: PNG as `serve` stores it
// by default (level 0) and compressed (levels 1 and 6), WebP lossless and lossy (libwebp) and
// AVIF (libavif, fastest speed, 4:4:4). Prints bytes and encode ms per tile, each as a ratio to
// the default PNG measured in the same run, and checks every tile decodes (OpenImageIO) to the
// PNG's pixels (lossless WebP exactly; the lossy ones within a PSNR printed per row), decoded by
// libwebp and libavif (tests/support/web_decode.h).
//
//   format_bench [EXEMPLAR_DIR] [TILES]
#include "render/cpu_backend.h"
#include "server/io/image_io.h"
#include "server/io/web_image.h"
#include "tests/bench/bench_texton.h"
#include "tests/support/test_support.h"
#include "tests/support/web_decode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

using namespace textond;

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// PSNR (dB) of `got` against the 8-bit values of `want` (the PNG's); infinity when equal.
double psnr(const core::Image& want, const core::Image& got) {
    double se = 0;
    std::size_t n = 0;
    for (int c = 0; c < 3; ++c)
        for (int y = 0; y < want.height; ++y)
            for (int x = 0; x < want.width; ++x) {
                const double a = want.at(std::min(c, want.channels - 1), x, y);
                const double b = got.at(std::min(c, got.channels - 1), x, y);
                se += (a - b) * (a - b);
                ++n;
            }
    return se == 0 ? INFINITY : 10 * std::log10(1.0 / (se / static_cast<double>(n)));
}

} // namespace

int main(int argc, char** argv) {
    const std::string dir = argc > 1 ? argv[1] : TEXTOND_EXEMPLARS;
    const int tiles = argc > 2 ? std::max(1, std::atoi(argv[2])) : 16;
    std::vector<core::Image> images;
    render::CpuBackend cpu(1);
    for (const char* name : {"etr_sand01.png", "mypaint_HR_Cork.png", "skimage_gravel.png"}) {
        auto prepared = test::bench_texton(dir + "/" + name, 20);
        if (!prepared) {
            std::fprintf(stderr, "format_bench: %s\n", prepared.error().message.c_str());
            return 1;
        }
        for (int k = 0; k < tiles; ++k) {
            render::NoiseRequest q;
            q.x0 = 256 * k;
            q.seed = 7;
            auto img = cpu.render(*prepared.value(), q);
            if (!img) return 1;
            images.push_back(std::move(img.value()));
        }
    }
    // The PNG each tile is served as today: the reference for every ratio and every pixel.
    std::vector<core::Image> reference;
    for (const auto& img : images)
        reference.push_back(
            io::decode_image_memory(io::encode_image_memory(img, io::Encoding::png8, {}, 0).value())
                .value());
    using Encode = std::function<Result<std::string>(const core::Image&)>;
    using Decode = std::function<Result<core::Image>(const std::string&)>;
    const Decode png = [](const std::string& b) { return io::decode_image_memory(b); };
    const Decode webp = [](const std::string& b) { return test::decode_webp(b); };
    const Decode avif = [](const std::string& b) { return test::decode_avif(b); };
    struct Row {
        std::string name;
        Encode encode;
        bool lossless;
        Decode decode;
    };
    const std::vector<Row> rows = {
        {"PNG, stored (serve's default)",
         [](const core::Image& u) { return io::encode_image_memory(u, io::Encoding::png8, {}, 0); },
         true, png},
        {"PNG, zlib 1",
         [](const core::Image& u) { return io::encode_image_memory(u, io::Encoding::png8, {}, 1); },
         true, png},
        {"PNG, zlib 6",
         [](const core::Image& u) { return io::encode_image_memory(u, io::Encoding::png8, {}, 6); },
         true, png},
        {"WebP lossless", [](const core::Image& u) { return io::encode_webp(u, 0); }, true, webp},
        {"WebP quality 90", [](const core::Image& u) { return io::encode_webp(u, 90); }, false,
         webp},
        {"WebP quality 75", [](const core::Image& u) { return io::encode_webp(u, 75); }, false,
         webp},
        {"AVIF quality 80 (default)", [](const core::Image& u) { return io::encode_avif(u, 80); },
         false, avif},
        {"AVIF quality 60", [](const core::Image& u) { return io::encode_avif(u, 60); }, false,
         avif},
    };
    const auto n = static_cast<double>(images.size());
    std::printf("%zu tiles of 256x256 (3 exemplars, colour and grey); ratios against the first "
                "row, measured in this run\n",
                images.size());
    std::printf(
        "| format | bytes/tile | bytes ratio | encode ms/tile | encode ratio | worst PSNR |\n"
        "|---|---|---|---|---|---|\n");
    double base_bytes = 0, base_ms = 0;
    bool ok = true;
    for (const Row& row : rows) {
        std::vector<std::string> out;
        out.reserve(images.size());
        const auto t0 = std::chrono::steady_clock::now();
        for (const auto& img : images) {
            auto bytes = row.encode(img);
            if (!bytes) {
                std::fprintf(stderr, "format_bench: %s: %s\n", row.name.c_str(),
                             bytes.error().message.c_str());
                return 1;
            }
            out.push_back(std::move(bytes.value()));
        }
        const double ms = ms_since(t0);
        double bytes = 0, worst = INFINITY;
        for (std::size_t i = 0; i < out.size(); ++i) {
            bytes += static_cast<double>(out[i].size());
            auto back = row.decode(out[i]);
            if (!back) {
                std::fprintf(stderr, "format_bench: %s does not decode: %s\n", row.name.c_str(),
                             back.error().message.c_str());
                return 1;
            }
            worst = std::min(worst, psnr(reference[i], back.value()));
        }
        if (row.lossless && std::isfinite(worst)) {
            std::fprintf(stderr, "format_bench: %s is not lossless (PSNR %.1f dB)\n",
                         row.name.c_str(), worst);
            ok = false;
        }
        if (base_bytes == 0) {
            base_bytes = bytes;
            base_ms = ms;
        }
        char psnr_text[32];
        std::snprintf(psnr_text, sizeof psnr_text, std::isfinite(worst) ? "%.1f dB" : "exact",
                      worst);
        std::printf("| %s | %.0f | %.3f | %.3f | %.2f | %s |\n", row.name.c_str(), bytes / n,
                    bytes / base_bytes, ms / n, ms / base_ms, psnr_text);
    }
    return ok ? 0 : 1;
}
