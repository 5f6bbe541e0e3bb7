#pragma once
// The OpenGL evaluator shared by the OSMesa and EGL backends: the same GLSL (render/glsl/) on
// whatever context the platform code made. Owns its context, made current on the calling thread
// for one batch and released after, so any thread may call it. Noise is evaluated in batches: the
// windows are prepared on their callers' threads (no GL), then one batch uploads them, dispatches
// them together and reads them back (render_batch); a single render is a batch of one.
#include "render/backend.h"
#include "render/gl/fence_wait.h"
#include "render/surface_eval.h"

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::render {

namespace gl {
struct GlApi;
}

namespace gl {
struct NoiseWindow;
struct BatchPlan;
struct Pass;
} // namespace gl

// A platform's GL context (OSMesa, EGL).
class GlContext {
public:
    virtual ~GlContext() = default;
    virtual bool make_current() = 0;
    virtual void release() = 0;
    virtual void* proc_address(const char* name) = 0;
    virtual std::string platform() const = 0; // e.g. "EGL device 0 (EGL_EXT_platform_device)"
};

// The noise's GLSL: render/glsl/ by default; the engine kit's copy in its test. The backend runs
// lib + eval as compute (texton_noise.comp); a fragment entry point (vert, frag), when given, is
// compiled against the same lib + eval and linked as a check only.
struct GlslSources {
    std::string lib, eval, vert, frag;
    static GlslSources embedded();
};

class GlBackend final : public Backend {
public:
    // Loads GL 4.5 functions, checks GL_RENDERER and compiles the noise program. A software
    // renderer (llvmpipe, softpipe, swrast) is refused unless `allow_software`.
    static Result<std::shared_ptr<GlBackend>>
    create(std::string name, std::unique_ptr<GlContext> context, bool allow_software,
           const GlslSources& sources = GlslSources::embedded());
    ~GlBackend() override;

    std::string name() const override { return m_name; }
    std::string renderer() const override;
    bool software() const { return m_software; }
    // GL_SUBPIXEL_BITS: the rasteriser snaps vertices to 2^-bits of a pixel (mesh previews).
    int subpixel_bits() const { return m_subpixel_bits; }
    Result<core::Image> render(const PreparedTexton& texton, const NoiseRequest& request,
                               RenderStats* stats = nullptr) override;
    // Every request in one batch.
    std::vector<Result<core::Image>> render_many(const PreparedTexton& texton,
                                                 const std::vector<NoiseRequest>& requests,
                                                 RenderStats* stats = nullptr) override;

    // One window of a batch: prepared on any thread (no GL), then rendered by render_batch.
    struct Work {
        std::unique_ptr<gl::NoiseWindow> window;
        Result<core::Image> image = make_error(ErrorCode::internal, "not rendered");
        RenderStats stats; // gpu_ms: the whole batch's passes that held this window
        // marginals=exemplar: the level's tables, applied on the host to the floats read back.
        std::shared_ptr<const core::MarginalTables> marginals;
        Work();
        Work(Work&&) noexcept;
        ~Work();
    };
    // Checks the request; `mix` null for one texton (else its exact levels only: unsupported
    // above them).
    Result<Work> prepare(const PreparedTexton& texton, const PreparedMix* mix,
                         const NoiseRequest& request) const;
    // Evaluates every window (texton_noise.comp, TEXTOND_BATCH): the windows are cut into
    // pieces that fit one pass's output buffer, and each pass is one dispatch per level table
    // (one for all tiles of a texton and level), quantised on the GPU to each request's
    // precision and copied back asynchronously (two passes in flight, fences); then each
    // Work's image holds its window, or the error that stopped it. Returns the batch's GPU ms.
    double render_batch(const std::vector<Work*>& batch);
    // Exact levels of a mix (its level tables as one texture array, the field in the shader);
    // the limit levels are left to the CPU (unsupported).
    Result<core::Image> render_mix(const PreparedMix& mix, const NoiseRequest& request,
                                   RenderStats* stats = nullptr) override;

    // Surface noise (render/glsl/surface_noise.comp) at `y` (texels, x y z a point, each within
    // +-2^31) with normals; returns 3 floats a point (grey textons repeat their channel).
    Result<std::vector<float>> surface(const PreparedTexton& texton, std::uint64_t seed, double mni,
                                       const std::vector<double>& y,
                                       const std::vector<float>& normals);

    // The mesh drawn by OpenGL from `view`, each fragment the surface noise at its position
    // (glsl/mesh_preview.*): RGBA, clear background, as render_mesh_preview draws it on the CPU.
    Result<core::Image> mesh_preview(const PreparedTexton& texton, std::uint64_t seed, double mni,
                                     const core::TriangleMesh& mesh, const MeshView& view,
                                     int width, int height);

    // Where exact levels' points come from: listed on the host (llvmpipe: no barriers), or drawn
    // by each workgroup into shared memory (a GPU). The same bits either way; the setter is a
    // test and bench hook. `mark_overflow` (tests): a group whose points overflow shared memory
    // writes -1e30 instead of falling back to the per-pixel gather, so a test sees which ran.
    enum class PointKernel { host_listed, shared };
    PointKernel point_kernel() const { return m_kernel; }
    void set_point_kernel(PointKernel k, bool mark_overflow = false);

    // Test hook: pretend storage buffers hold at most `bytes` (batches split below it).
    void limit_storage_block(std::size_t bytes) { m_max_block_bytes = bytes; }
    std::size_t pass_words() const; // output words a pass: fewer on a software renderer
    // Bench hooks: another pass size (0: the default; its buffers are remade), and the GPU ms of
    // each pass of the last batch.
    void set_pass_words(std::size_t words);
    std::vector<double> last_pass_ms();

    // Test hook: runs render/glsl/spec_probe.comp on `queries` (8 words each) with the given
    // Poisson thresholds; returns 64 words per query.
    Result<std::vector<std::uint32_t>> probe(const std::vector<std::uint32_t>& queries,
                                             const std::vector<std::uint32_t>& thresholds);

private:
    GlBackend(std::string name, std::unique_ptr<GlContext> context);
    Result<bool> init(bool allow_software, const GlslSources& sources);

    std::string m_name;
    std::unique_ptr<GlContext> m_context;
    std::unique_ptr<gl::GlApi> m_gl;
    std::string m_renderer;
    std::string m_version;
    bool m_software = false;
    PointKernel m_kernel = PointKernel::host_listed;
    bool m_mark_overflow = false;
    int m_shared_points = 0; // the shared list's capacity in points (the device's shared memory)
    int m_subpixel_bits = 4;
    std::mutex m_mutex;         // the context: one batch (or surface, mesh, probe call) at a time
    std::string m_noise_source; // lib + eval + comp, compiled per output precision
    // The batched noise program, one per Precision (f32 made at start, the others when first
    // needed), and its uniforms.
    struct NoiseProgram {
        unsigned id = 0;
        int tile_first = -1, mask = -1;
    };
    NoiseProgram m_noise[3];
    Result<NoiseProgram*> noise_program(Precision p);
    unsigned m_probe_program = 0, m_surface_program = 0, m_mesh_program = 0, m_vao = 0;
    // A pass's output (written by the shader) and the persistently mapped copy it is read from,
    // two of them so one pass computes while the one before is copied back.
    struct Slot {
        unsigned out = 0, readback = 0, query = 0;
        const std::uint32_t* mapped = nullptr;
        void* fence = nullptr; // GLsync of the pass in flight
        double host_ms = -1;   // software renderers: the dispatches' time on the host clock
        std::chrono::steady_clock::time_point dispatched; // when its dispatches were issued
    };
    Slot m_slots[2];
    std::size_t m_pass_words = 0;     // set_pass_words; 0: by renderer
    std::size_t m_slot_words = 0;     // what the slots were made for
    std::vector<double> m_pass_ms;    // the last batch's
    gl::PassTimeEstimate m_pass_time; // how long a pass of n pixels keeps the GPU, for its wait
    void release_slot(Slot& slot);    // deletes what it holds, leaves it empty
    std::size_t m_max_block_bytes = std::size_t{128} << 20; // GL_MAX_SHADER_STORAGE_BLOCK_SIZE
    // Storage buffers grown as needed and reused: 0 cell starts (binding 1), 1 points (2), 2 a
    // mix's level tables (3), 3 the records (4), 4 the thresholds (5).
    unsigned m_buffers[5] = {0, 0, 0, 0, 0};
    std::size_t m_capacity[5] = {0, 0, 0, 0, 0};
    void upload(int k, const void* data, std::size_t bytes);

    // render_batch's phases after gl::plan_batch (batch_plan.h, no GL), the context current:
    // the slots mapped, then the passes run, two in flight.
    std::optional<Error> map_slots();
    double run_passes(const gl::BatchPlan& plan, const std::vector<Work*>& batch);
    std::optional<Error> dispatch_pass(const gl::Pass& pass, int slot, const gl::BatchPlan& plan,
                                       std::vector<unsigned>& masks);
    std::optional<Error> finish_pass(int slot, const gl::Pass& pass, double& gpu_ms);

    // Uniforms shared by surface_lib.glsl's users (the compute and the mesh programs).
    void set_surface_uniforms(unsigned program, const PreparedTexton& texton, std::uint64_t seed,
                              double mni);
    // Level tables uploaded once and kept (at most 32 of each kind): RGB32F textures for the
    // surface and mesh programs, vec4 storage buffers for the noise.
    struct CachedTable {
        unsigned object = 0; // the texture or buffer
    };
    // By the table's serial, unique in the process: the host table may be freed meanwhile (the
    // table budget), and another made at its address must not find this one's copy.
    struct TableCache {
        bool buffers = false;
        std::map<std::uint64_t, CachedTable> entries;
    };
    TableCache m_table_textures{false, {}}, m_table_buffers{true, {}};
    unsigned cached_table(TableCache& cache, const std::shared_ptr<const LevelTable>& table);
    void delete_table(const TableCache& cache, unsigned object);
    Result<core::Image> render_one(const PreparedTexton& texton, const PreparedMix* mix,
                                   const NoiseRequest& request, RenderStats* stats);
};

} // namespace textond::render
