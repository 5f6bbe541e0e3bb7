// What a GL backend's host spends on an 8-bit window after the GPU: its readback words (one a
// pixel, the channels in the low bytes, rounded on the GPU as the PNG encoder rounds) made into
// the response. As floats (the words divided into planes, then interleaved and rounded
// back by the encoder) against as bytes (NoiseRequest::bytes: the words' bytes straight into what
// the encoder takes). For 256x256 tiles, copy and PNG encode (zlib level 0, as `serve` stores
// tiles), and for a 4K frame the copy alone, each as ms and as a ratio to floats in the same
// run. No GPU is needed: the words are a CPU tile rounded as the shader rounds them. Exits 1
// unless both give the same PNG bytes.
//
//   readback_bench [EXEMPLAR_DIR] [TILES]
#include "render/cpu_backend.h"
#include "render/gl/batch_plan.h"
#include "render/gl/noise_window.h"
#include "render/image_buffers.h"
#include "server/io/image_io.h"
#include "tests/bench/bench_texton.h"
#include "tests/support/test_support.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <malloc.h>
#include <string>
#include <vector>

using namespace textond;

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

// The words a GL pass reads back for `u` at 8 bits (glsl/texton_noise.comp, store_pixel).
std::vector<std::uint32_t> words_of(const core::Image& u) {
    std::vector<std::uint32_t> w(u.plane_size(), 0);
    for (int c = 0; c < u.channels; ++c)
        for (std::size_t k = 0; k < u.plane_size(); ++k) {
            const float v = std::clamp(u.plane(c)[k], 0.0f, 1.0f) * 255.0f + 0.5f;
            w[k] |= static_cast<std::uint32_t>(v) << (8 * c);
        }
    return w;
}

// One window's readback into its image, as render_batch does it (copy_out_pass).
core::Image copy_out(const std::vector<std::uint32_t>& words, int w, int h, int channels,
                     bool bytes) {
    render::GlBackend::Work work;
    work.window = std::make_unique<render::gl::NoiseWindow>();
    work.window->width = w;
    work.window->height = h;
    work.window->channels = channels;
    work.window->precision = render::Precision::u8;
    work.window->bytes = bytes;
    work.image =
        bytes ? render::take_bytes_image(w, h, channels) : render::take_image(w, h, channels);
    render::gl::Pass pass{render::Precision::u8, words.size(), {}, 0};
    pass.pieces.push_back({&work, 0, 0, w, h, 0, nullptr});
    render::gl::copy_out_pass(pass, words.data());
    return std::move(work.image.value());
}

} // namespace

int main(int argc, char** argv) {
    // As `serve` tunes malloc (tune_malloc in serve_command.cpp): a frame's image is then a fresh
    // mapping each time, whose page faults are part of what a served frame costs.
    ::mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    ::mallopt(M_TRIM_THRESHOLD, 1024 * 1024);
    const std::string dir = argc > 1 ? argv[1] : TEXTOND_EXEMPLARS;
    const int tiles = argc > 2 ? std::max(1, std::atoi(argv[2])) : 400;
    auto prepared = test::bench_texton(dir + "/etr_sand01.png", 10);
    if (!prepared) {
        std::fprintf(stderr, "readback_bench: %s\n", prepared.error().message.c_str());
        return 1;
    }
    render::CpuBackend cpu;
    render::NoiseRequest q;
    auto tile = cpu.render(*prepared.value(), q);
    q.width = 3840;
    q.height = 2160;
    auto frame = cpu.render(*prepared.value(), q);
    if (!tile || !frame) return 1;
    const int nc = tile.value().channels;
    const auto tile_words = words_of(tile.value());
    const auto frame_words = words_of(frame.value());

    std::printf("| 8-bit GL window to response (%d channels) | as floats ms | as bytes ms | "
                "bytes / floats |\n|---|---|---|---|\n",
                nc);
    std::vector<double> copy[2], encode[2], total[2];
    for (int i = -10; i < tiles; ++i)
        for (int bytes = 0; bytes < 2; ++bytes) { // alternated: the machine's drift hits both
            const auto t0 = Clock::now();
            core::Image img = copy_out(tile_words, 256, 256, nc, bytes != 0);
            const auto t1 = Clock::now();
            auto png = io::encode_image_memory(img, io::Encoding::png8, {}, 0);
            render::recycle_image(std::move(img));
            const double c = std::chrono::duration<double, std::milli>(t1 - t0).count();
            const double e = ms_since(t1);
            if (!png) return 1;
            static std::string first;
            if (i == -10 && bytes == 0) first = png.value();
            if (png.value() != first) {
                std::fprintf(stderr, "readback_bench: the bytes' PNG differs from the floats'\n");
                return 1;
            }
            io::recycle_encoded(std::move(png.value()));
            if (i < 0) continue;
            copy[bytes].push_back(c);
            encode[bytes].push_back(e);
            total[bytes].push_back(c + e);
        }
    auto row = [](const char* what, const std::vector<double>* v) {
        const double f = median(v[0]), b = median(v[1]);
        std::printf("| %s | %.4f | %.4f | %.2f |\n", what, f, b, b / f);
    };
    row("256x256 tile: readback copy", copy);
    row("256x256 tile: PNG encode (level 0)", encode);
    row("256x256 tile: both", total);
    std::vector<double> frames[2];
    for (int i = -1; i < std::max(3, tiles / 40); ++i)
        for (int bytes = 0; bytes < 2; ++bytes) {
            const auto t0 = Clock::now();
            core::Image img = copy_out(frame_words, 3840, 2160, nc, bytes != 0);
            if (i >= 0) frames[bytes].push_back(ms_since(t0));
        }
    row("3840x2160 frame: readback copy (all cores)", frames);
    return 0;
}
