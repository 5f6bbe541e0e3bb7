#include "render/backend_factory.h"

#include "render/cpu_backend.h"
#include "render/gl/egl_backend.h"
#include "render/gl/gl_backend.h"
#include "render/gl/osmesa_backend.h"
#include "render/settled.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

namespace textond::render {

namespace {

// A fixed r = 64 texton (smooth coefficients, no analysis): what the calibration renders. The
// cost of texton noise depends on r, the order and the MNI, not on the coefficients.
std::shared_ptr<const PreparedTexton> calibration_texton() {
    static const std::shared_ptr<const PreparedTexton> t = [] {
        core::Texton x;
        x.size = 64;
        x.channels = 3;
        x.order = 1;
        x.mean = {0.5, 0.5, 0.5};
        x.alpha = core::Image(64, 64, 3);
        for (int c = 0; c < 3; ++c)
            for (int y = 0; y < 64; ++y)
                for (int i = 0; i < 64; ++i)
                    x.alpha.at(c, i, y) =
                        static_cast<float>(0.01 * std::sin(0.3 * i + 0.7 * y + c));
        return PreparedTexton::make(x).value();
    }();
    return t;
}

std::string figures_text(const std::vector<Calibration>& figures) {
    std::string s;
    for (const auto& f : figures) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "%s%s 16 tiles %.1f ms (%d rounds), HD frame %.1f ms (%d)",
                      s.empty() ? "" : "; ", f.backend.c_str(), f.tile_ms, f.tile_rounds,
                      f.frame_ms, f.frame_rounds);
        s += buf;
    }
    return s;
}

} // namespace

Result<Calibration> calibrate(const std::vector<Backend*>& tile_workers, Backend& frames,
                              bool quick) {
    const int side = quick ? 64 : 256;
    const auto tex = calibration_texton();
    Calibration out;
    out.backend = frames.name();
    std::uint64_t seed = 1000;
    NoiseRequest frame, tile;
    frame.width = quick ? 480 : 1920;
    frame.height = quick ? 270 : 1080;
    tile.width = tile.height = side;
    auto render = [&](Backend& b, NoiseRequest q) -> std::optional<Error> {
        q.seed = ++seed;
        auto r = b.render(*tex, q);
        if (!r) return r.error();
        return std::nullopt;
    };
    // First uses build tables and upload textures (and compile shaders): not measured.
    if (auto warm = render(frames, frame)) return *warm;
    tile.precision = Precision::u8; // as a PNG tile is read back (its own GL program), as bytes
    tile.bytes = true;
    for (Backend* w : tile_workers)
        if (auto warm = render(*w, tile)) return *warm;
    // Sixteen tiles on every worker at once: one batch a lane on GL, one after another on each
    // CPU slot, so a GPU's lanes overlap and the CPU's slots share the cores as when serving.
    const double least_ms = quick ? 0 : 400, most_ms = quick ? 1000 : 3000;
    auto sixteen = settled_ms(least_ms, most_ms, [&]() -> std::optional<Error> {
        const std::size_t n = tile_workers.size();
        std::vector<std::optional<Error>> errors(n);
        std::vector<std::vector<NoiseRequest>> qs(n, std::vector<NoiseRequest>(16, tile));
        for (std::size_t w = 0; w < n; ++w)
            for (int t = 0; t < 16; ++t) {
                NoiseRequest& q = qs[w][static_cast<std::size_t>(t)];
                q.x0 = side * (t % 4) + 4 * side * static_cast<std::int64_t>(w);
                q.y0 = side * (t / 4);
                q.seed = ++seed;
            }
        auto one = [&](std::size_t w) {
            for (auto& r : tile_workers[w]->render_many(*tex, qs[w]))
                if (!r && !errors[w]) errors[w] = r.error();
        };
        std::vector<std::thread> threads;
        for (std::size_t w = 1; w < n; ++w) threads.emplace_back(one, w);
        if (n > 0) one(0);
        for (auto& t : threads) t.join();
        for (auto& e : errors)
            if (e) return e;
        return std::nullopt;
    });
    if (!sixteen) return sixteen.error();
    auto whole = settled_ms(least_ms, most_ms, [&] { return render(frames, frame); });
    if (!whole) return whole.error();
    out.tile_ms =
        sixteen.value().ms / static_cast<double>(std::max<std::size_t>(1, tile_workers.size()));
    out.tile_rounds = sixteen.value().rounds;
    out.frame_ms = whole.value().ms;
    out.frame_rounds = whole.value().rounds;
    return out;
}

std::pair<std::size_t, std::size_t> pick_fastest(const std::vector<Calibration>& figures) {
    std::size_t tiles = 0, frames = 0;
    for (std::size_t i = 1; i < figures.size(); ++i) {
        if (figures[i].tile_ms < figures[tiles].tile_ms) tiles = i;
        if (figures[i].frame_ms < figures[frames].frame_ms) frames = i;
    }
    return {tiles, frames};
}

int gl_lanes(const BackendOptions& options, const GlBackend& gl) {
    if (options.gl_lanes > 0) return options.gl_lanes;
    return gl.software() ? 1 : 3;
}

std::vector<std::shared_ptr<GlBackend>> make_gl_lanes(std::shared_ptr<GlBackend> first,
                                                      const BackendOptions& options,
                                                      std::string* failure) {
    const GlBackend& gl = *first;
    std::vector<std::shared_ptr<GlBackend>> lanes{std::move(first)};
    while (static_cast<int>(lanes.size()) < gl_lanes(options, gl)) {
        auto lane = gl.name() == "egl" ? make_egl_backend(options.allow_software_egl)
                                       : make_osmesa_backend();
        if (!lane) {
            if (failure) *failure = lane.error().message;
            break;
        }
        lane.value()->set_point_kernel(gl.point_kernel());
        lanes.push_back(std::move(lane.value()));
    }
    return lanes;
}

Result<BackendKind> parse_backend_kind(std::string_view name) {
    if (name == "auto") return BackendKind::automatic;
    if (name == "cpu") return BackendKind::cpu;
    if (name == "osmesa") return BackendKind::osmesa;
    if (name == "egl") return BackendKind::egl;
    return make_error(ErrorCode::invalid_argument,
                      "unknown backend '" + std::string(name) + "' (auto, cpu, osmesa or egl)");
}

const char* to_string(BackendKind kind) {
    switch (kind) {
    case BackendKind::automatic:
        return "auto";
    case BackendKind::cpu:
        return "cpu";
    case BackendKind::osmesa:
        return "osmesa";
    case BackendKind::egl:
        return "egl";
    }
    return "?";
}

Result<BackendChoice> make_backend(BackendKind kind, const BackendOptions& options) {
    auto cpu = [&](const std::string& reason) {
        auto b = std::make_shared<CpuBackend>(options.threads);
        return BackendChoice{b, nullptr, reason + b->renderer(), {}, {}};
    };
    switch (kind) {
    case BackendKind::cpu:
        return cpu("asked for cpu: ");
    case BackendKind::osmesa: {
        auto b = make_osmesa_backend();
        if (!b) return b.error();
        return BackendChoice{
            b.value(), nullptr, "asked for osmesa: " + b.value()->renderer(), {}, {}};
    }
    case BackendKind::egl: {
        auto b = make_egl_backend(options.allow_software_egl);
        if (!b) return b.error();
        return BackendChoice{b.value(), nullptr, "asked for egl: " + b.value()->renderer(), {}, {}};
    }
    case BackendKind::automatic: {
        auto b = make_egl_backend(options.allow_software_egl);
        if (!b) return cpu("auto: no GPU (" + b.error().message + "), so ");
        // Measure: the CPU path as the server runs it (tiles on one thread each, as many at
        // once as it has slots; frames on every thread) against the GPU.
        const int slots = options.tile_slots > 0
                              ? options.tile_slots
                              : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        auto all = std::make_shared<CpuBackend>(options.threads);
        auto one = std::make_shared<CpuBackend>(1);
        const bool quick = options.quick_calibration;
        auto lanes = make_gl_lanes(b.value(), options); // the batcher says how many it has
        auto on_cpu = calibrate(std::vector<Backend*>(static_cast<std::size_t>(slots), one.get()),
                                *all, quick);
        std::vector<Backend*> gpu_workers;
        gpu_workers.reserve(lanes.size());
        for (const auto& lane : lanes) gpu_workers.push_back(lane.get());
        auto gpu = calibrate(gpu_workers, *b.value(), quick);
        if (!on_cpu) return make_error(ErrorCode::internal, "auto: the CPU calibration failed");
        if (!gpu)
            return cpu("auto: the GPU (" + b.value()->renderer() +
                       ") failed its calibration: " + gpu.error().message + "; so ");
        std::vector<Calibration> figures = {on_cpu.value(), gpu.value()};
        const auto [t, f] = pick_fastest(figures);
        BackendChoice c;
        c.backend = f == 0 ? std::static_pointer_cast<Backend>(all) : b.value();
        c.tiles = t == 0 ? std::static_pointer_cast<Backend>(one) : b.value();
        c.calibration = figures;
        if (t == 1 || f == 1) c.lanes = std::move(lanes);
        c.reason = std::string("auto, measured (") + figures_text(figures) + "): tiles on " +
                   c.tiles->name() + ", frames on " + c.backend->name() + "; " +
                   b.value()->renderer();
        return c;
    }
    }
    return make_error(ErrorCode::internal, "unknown backend kind");
}

} // namespace textond::render
