// zlib against libdeflate on the bytes a compressed PNG tile deflates: 256x256 8-bit
// RGB tiles of texton noise from the shared exemplars, each row behind PNG's Average filter (what
// `serve --png-compression N` asks libpng for), compressed as one zlib stream by each library at
// the same levels. Prints bytes and ms per tile next to what `serve` does today (OpenImageIO's PNG
// writer: stored at level 0, zlib at 1..9). Every stream is inflated back and checked.
//
//   deflate_bench [EXEMPLAR_DIR] [TILES]
#include "render/cpu_backend.h"
#include "server/io/image_io.h"
#include "tests/bench/bench_texton.h"
#include "tests/support/test_support.h"

#include <libdeflate.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace textond;

namespace {

// PNG's filter type 3 (Average) in front of each row, as libpng writes it.
std::vector<unsigned char> average_filtered(const core::Image& img) {
    const int w = img.width, h = img.height, nc = img.channels;
    const std::size_t row = static_cast<std::size_t>(w) * nc;
    std::vector<unsigned char> raw(row * h), out;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < nc; ++c)
                raw[y * row + static_cast<std::size_t>(x) * nc + c] = static_cast<unsigned char>(
                    std::clamp(img.at(c, x, y), 0.0f, 1.0f) * 255.0f + 0.5f);
    out.reserve((row + 1) * h);
    for (int y = 0; y < h; ++y) {
        out.push_back(3);
        for (std::size_t i = 0; i < row; ++i) {
            const int left = i >= static_cast<std::size_t>(nc) ? raw[y * row + i - nc] : 0;
            const int up = y > 0 ? raw[(y - 1) * row + i] : 0;
            out.push_back(static_cast<unsigned char>(raw[y * row + i] - (left + up) / 2));
        }
    }
    return out;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

int main(int argc, char** argv) {
    const std::string dir = argc > 1 ? argv[1] : TEXTOND_EXEMPLARS;
    const int tiles = argc > 2 ? std::max(1, std::atoi(argv[2])) : 32;
    std::vector<std::vector<unsigned char>> inputs;
    std::vector<core::Image> images;
    render::CpuBackend cpu(1);
    for (const char* name : {"etr_sand01.png", "mypaint_HR_Cork.png", "skimage_gravel.png"}) {
        auto prepared = test::bench_texton(dir + "/" + name, 20);
        if (!prepared) {
            std::fprintf(stderr, "deflate_bench: %s\n", prepared.error().message.c_str());
            return 1;
        }
        for (int k = 0; k < tiles; ++k) {
            render::NoiseRequest q;
            q.x0 = 256 * k;
            q.seed = 7;
            auto img = cpu.render(*prepared.value(), q);
            if (!img) return 1;
            inputs.push_back(average_filtered(img.value()));
            images.push_back(img.value());
        }
    }
    std::size_t raw = 0, largest = 0;
    for (const auto& in : inputs) {
        raw += in.size();
        largest = std::max(largest, in.size());
    }
    const auto n_tiles = static_cast<double>(inputs.size());
    std::printf("%zu tiles of 256x256 (3 exemplars, colour and grey), %.0f filtered bytes a tile\n",
                inputs.size(), static_cast<double>(raw) / n_tiles);
    std::printf(
        "| encoder | level | bytes/tile | of filtered | ms/tile |\n|---|---|---|---|---|\n");
    auto row = [&](const std::string& name, int level, std::size_t bytes, double ms) {
        std::printf("| %s | %d | %.0f | %.1f%% | %.3f |\n", name.c_str(), level,
                    static_cast<double>(bytes) / n_tiles,
                    100.0 * static_cast<double>(bytes) / static_cast<double>(raw), ms / n_tiles);
    };
    std::vector<unsigned char> back(largest);
    bool ok = true;
    for (int level : {1, 6, 9}) {
        std::vector<unsigned char> z(compressBound(largest));
        std::size_t bytes = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (const auto& in : inputs) {
            uLongf n = z.size();
            compress2(z.data(), &n, in.data(), in.size(), level);
            bytes += n;
            uLongf m = back.size();
            ok = ok && uncompress(back.data(), &m, z.data(), n) == Z_OK && m == in.size() &&
                 std::equal(in.begin(), in.end(), back.begin());
        }
        const double ms = ms_since(t0);
        row(std::string("zlib ") + zlibVersion(), level, bytes, ms);
    }
    libdeflate_decompressor* inflate = libdeflate_alloc_decompressor();
    for (int level : {1, 6, 9, 12}) {
        libdeflate_compressor* c = libdeflate_alloc_compressor(level);
        std::vector<unsigned char> z(libdeflate_zlib_compress_bound(c, largest));
        std::size_t bytes = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (const auto& in : inputs) {
            const std::size_t n =
                libdeflate_zlib_compress(c, in.data(), in.size(), z.data(), z.size());
            bytes += n;
            std::size_t m = 0;
            ok = ok && n > 0 &&
                 libdeflate_zlib_decompress(inflate, z.data(), n, back.data(), back.size(), &m) ==
                     LIBDEFLATE_SUCCESS &&
                 m == in.size() && std::equal(in.begin(), in.end(), back.begin());
        }
        const double ms = ms_since(t0);
        libdeflate_free_compressor(c);
        row(std::string("libdeflate ") + LIBDEFLATE_VERSION_STRING, level, bytes, ms);
    }
    libdeflate_free_decompressor(inflate);
    // What serve does today: the whole PNG through OpenImageIO (libpng + zlib).
    for (int level : {0, 1, 6}) {
        std::size_t bytes = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (const auto& img : images) {
            auto png = io::encode_image_memory(img, io::Encoding::png8, {}, level);
            ok = ok && png.ok();
            if (png) bytes += png.value().size();
        }
        const double ms = ms_since(t0);
        row("OpenImageIO PNG (serve; whole file)", level, bytes, ms);
    }
    if (!ok) std::fprintf(stderr, "deflate_bench: a stream did not inflate back to its input\n");
    return ok ? 0 : 1;
}
