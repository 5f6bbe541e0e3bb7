#pragma once
// Picks a backend by name and says why. `auto` measures: where EGL finds a GPU, a short
// calibration renders the same tiles and frame on it and on the CPU path, and each kind of work
// goes to the faster (never to a backend slower than the CPU); without a GPU it is the CPU path
// (on the same cores it is far faster than OSMesa's llvmpipe).
#include "core/result.h"
#include "render/backend.h"

#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace textond::render {

class GlBackend;

enum class BackendKind { automatic, cpu, osmesa, egl };

Result<BackendKind> parse_backend_kind(std::string_view name); // auto | cpu | osmesa | egl
const char* to_string(BackendKind kind);

struct BackendOptions {
    int threads = 0; // CPU backend; 0 = all cores
    // EGL normally refuses software renderers (llvmpipe) so they are never mistaken for a GPU;
    // tests set this to run the EGL code path on machines without one.
    bool allow_software_egl = false;
    // The CPU renders this many tiles at once (one thread each), so its tile throughput is this
    // many times one thread's; 0 = one per core.
    int tile_slots = 0;
    // GL: concurrent windows gathered into one batch (render/window_batcher.h): at most this many,
    // waiting at most this long for more once the first is queued.
    int batch_tiles = 64;
    int batch_wait_us = 200;
    int batch_ms = 25; // and at most about this much measured work (at least one window)
    // GL: batch workers, each with a context of its own (render/window_batcher.h); 0 = 3 on a
    // GPU, 1 on a software renderer (whose one dispatch already takes every core).
    int gl_lanes = 0;
    // Tests: calibrate on 64x64 tiles and a 480x270 frame (the same code, 1/16 of the work).
    bool quick_calibration = false;
};

// The lanes `options` asks of `gl`; and `first` followed by lanes like it (its kind and point
// kernel, a context each) up to that count, fewer where a context fails (`failure` then says why:
// a device that takes one context only gives fewer lanes, the same bits).
int gl_lanes(const BackendOptions& options, const GlBackend& gl);
std::vector<std::shared_ptr<GlBackend>> make_gl_lanes(std::shared_ptr<GlBackend> first,
                                                      const BackendOptions& options,
                                                      std::string* failure = nullptr);

// What the calibration of `auto` measured for one backend (milliseconds, the best round once the
// rounds settle: calibrate below).
struct Calibration {
    std::string backend;
    double tile_ms = 0;  // sixteen 256x256 8-bit tiles, as one batch (the CPU: one thread each,
                         // divided by the tiles it renders at once)
    double frame_ms = 0; // one 1920x1080 frame (the CPU: every thread)
    int tile_rounds = 0, frame_rounds = 0; // how many times each was measured
};

struct BackendChoice {
    std::shared_ptr<Backend> backend; // large windows (regions, tileable, spectra)
    std::shared_ptr<Backend> tiles;   // tiles; null = `backend` (the CPU path's tiles: one thread)
    std::string reason;               // what was tried and why this one was taken
    std::vector<Calibration> calibration; // auto with a GPU: every candidate's figures
    // auto with a GPU: the GL lanes it calibrated (the first is `backend` or `tiles`), for the
    // batcher to keep.
    std::vector<std::shared_ptr<GlBackend>> lanes;
};

// The calibration set: sixteen tiles on each of `tile_workers` at once, one thread each, as the
// server renders them (the CPU: one worker a render slot; GL: one a lane), and the frame on
// `frames`. tile_ms is the wall time over the workers: sixteen tiles' share of the throughput.
// Each is repeated until it settles (at least 400 ms and three rounds in a row no faster by 5%,
// at most 3 s; quick: no least, at most 1 s), since a GPU idles at a fraction of its clock until
// it has been busy a while; the best round counts.
Result<Calibration> calibrate(const std::vector<Backend*>& tile_workers, Backend& frames,
                              bool quick = false);

// Which calibrated backend serves tiles and which frames: the fastest of each, the CPU's (entry 0)
// unless another beats it. Returns indices into `figures`.
std::pair<std::size_t, std::size_t> pick_fastest(const std::vector<Calibration>& figures);

Result<BackendChoice> make_backend(BackendKind kind, const BackendOptions& options = {});

} // namespace textond::render
