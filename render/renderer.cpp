#include "render/renderer.h"

#include "render/cpu_backend.h"
#include "render/gl/gl_backend.h"
#include "render/normal_map.h"
#include "render/window_batcher.h"

#include <cmath>

namespace textond::render {

Result<std::unique_ptr<Renderer>> Renderer::make(BackendKind kind, const BackendOptions& options) {
    auto choice = make_backend(kind, options);
    if (!choice) return choice.error();
    std::unique_ptr<Renderer> r(new Renderer());
    r->m_cpu_one = std::make_shared<CpuBackend>(1);
    r->m_cpu_all = std::make_shared<CpuBackend>(options.threads);
    std::shared_ptr<Backend> frames = choice.value().backend;
    std::shared_ptr<Backend> tiles = choice.value().tiles;
    if (frames->name() == "cpu") frames = r->m_cpu_all;
    if (!tiles) tiles = frames->name() == "cpu" ? r->m_cpu_one : frames;
    if (tiles->name() == "cpu") tiles = r->m_cpu_one; // small windows: one thread each
    r->m_frames = frames;
    r->m_tiles = tiles;
    r->m_frames_name = frames->name();
    r->m_tiles_name = tiles->name();
    r->m_gl = std::dynamic_pointer_cast<GlBackend>(frames);
    r->m_batched = r->m_gl ? r->m_gl : std::dynamic_pointer_cast<GlBackend>(tiles);
    std::string lanes_note;
    if (r->m_batched) {
        // auto calibrated its lanes already (the first is the batched backend).
        std::vector<std::shared_ptr<GlBackend>> lanes = choice.value().lanes;
        std::string failure;
        if (lanes.empty() || lanes.front() != r->m_batched)
            lanes = make_gl_lanes(r->m_batched, options, &failure);
        if (!failure.empty()) lanes_note = " (another context failed: " + failure + ")";
        lanes_note = "; GL batches in " + std::to_string(lanes.size()) + " lane" +
                     (lanes.size() == 1 ? "" : "s") + lanes_note;
        r->m_batcher = std::make_unique<WindowBatcher>(
            std::move(lanes), options.batch_tiles, std::chrono::microseconds(options.batch_wait_us),
            options.batch_ms);
    }
    r->m_reason = choice.value().reason + lanes_note;
    r->m_calibration = choice.value().calibration;
    auto identity = [](const Backend& b) {
        return b.name() == "cpu" ? std::string("cpu") : b.name() + ":" + b.renderer();
    };
    r->m_identity = identity(*tiles);
    if (identity(*frames) != r->m_identity) r->m_identity += "+" + identity(*frames);
    return r;
}

Renderer::~Renderer() = default;

// CPU seconds of llvmpipe (wall x cores) over server/app/work_cost.h's estimate of the same
// render, fitted on one render and checked on another (deploy/README.md "Hostile clients"): sand, r
// 32, 512 x 512 at MNI 30 and 200: 47 and 47; held out, pebbles, r 64, 768 x 512, MNI 100: 50.
constexpr double kSoftwareGlWorkFactor = 47.0;

double Renderer::work_factor() const {
    return m_gl && m_gl->software() ? kSoftwareGlWorkFactor : 1.0;
}

bool Renderer::all_batched() const {
    return m_batcher && m_tiles == m_batched && m_frames == m_batched;
}
int Renderer::gl_lanes() const {
    return m_batcher ? m_batcher->lanes() : 0;
}
std::uint64_t Renderer::batches() const {
    return m_batcher ? m_batcher->batches() : 0;
}
std::uint64_t Renderer::batched_windows() const {
    return m_batcher ? m_batcher->windows() : 0;
}

Result<core::Image> Renderer::on(Backend& b, const PreparedTexton& texton, const PreparedMix* mix,
                                 const NoiseRequest& request) {
    if (m_batcher && &b == m_batched.get()) return m_batcher->render(texton, mix, request);
    return mix ? b.render_mix(*mix, request) : b.render(texton, request);
}

Result<core::Image> Renderer::noise(const PreparedTexton& texton, const NoiseRequest& request,
                                    Work work, std::string* used) {
    Backend& b = work == Work::tile ? *m_tiles : *m_frames;
    if (used) *used = work == Work::tile ? m_tiles_name : m_frames_name;
    auto r = on(b, texton, nullptr, request);
    if (r || r.error().code != ErrorCode::unsupported) return r;
    // A path the backend does not have (GL: a material map's limit levels).
    CpuBackend& cpu = work == Work::tile ? *m_cpu_one : *m_cpu_all;
    if (used) *used = "cpu";
    return cpu.render(texton, request);
}

Result<core::Image> Renderer::normals(const PreparedTexton& height, const NoiseRequest& request,
                                      double strength, Work work) {
    return render_normal_map(work == Work::tile ? *m_cpu_one : *m_cpu_all, height, request,
                             strength);
}

Result<core::Image> Renderer::mix(const PreparedMix& mix, const NoiseRequest& request, Work work,
                                  std::string* used) {
    Backend& b = work == Work::tile ? *m_tiles : *m_frames;
    if (used) *used = work == Work::tile ? m_tiles_name : m_frames_name;
    auto r = on(b, mix.level(0), &mix, request);
    if (r || r.error().code != ErrorCode::unsupported) return r;
    // A path the backend does not have (GL: a mix's limit levels): the CPU has them all.
    CpuBackend& cpu = work == Work::tile ? *m_cpu_one : *m_cpu_all;
    if (used) *used = "cpu";
    return cpu.render_mix(mix, request);
}

Result<std::vector<float>> Renderer::surface(const PreparedTexton& texton,
                                             const SurfaceRequest& req,
                                             const std::vector<float>& points,
                                             const std::vector<float>& normals, std::string* used) {
    auto cpu = [&] {
        if (used) *used = "cpu";
        return evaluate_surface(texton.texton(), req, points, normals, 1);
    };
    if (!m_gl) return cpu();
    if (auto e = check_surface_input(req, points, normals)) return *e;
    // On a GL backend the GPU's colours (equal to the CPU's within float rounding).
    std::vector<double> y(points.size());
    for (std::size_t i = 0; i < y.size(); ++i) y[i] = double(points[i]) * req.scale;
    auto got = m_gl->surface(texton, req.seed, req.mni, y, normals);
    if (!got) return cpu(); // beyond the GPU path's +-2^31 texels
    if (used) *used = m_gl->name();
    const auto nc = static_cast<std::size_t>(texton.channels());
    std::vector<float> out(points.size() / 3 * nc);
    for (std::size_t i = 0; i < points.size() / 3; ++i)
        for (std::size_t c = 0; c < nc; ++c) out[i * nc + c] = got.value()[3 * i + c];
    return out;
}

Result<core::Image> Renderer::mesh_preview(const PreparedTexton& texton, const SurfaceRequest& req,
                                           const Mesh& mesh, const Camera& camera, int width,
                                           int height, std::string* used, const Relief& relief) {
    if (m_gl && !relief.height) {
        // OpenGL draws it (glsl/mesh_preview.*).
        auto view = mesh_view(mesh, req, camera, width, height);
        if (!view) return view.error();
        if (used) *used = m_gl->name();
        return m_gl->mesh_preview(texton, req.seed, req.mni, mesh, view.value(), width, height);
    }
    if (used) *used = "cpu";
    return render_mesh_preview(texton.texton(), req, mesh, camera, width, height, 0, relief);
}

} // namespace textond::render
