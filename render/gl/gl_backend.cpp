#include "render/gl/gl_backend.h"

#include "core/grid_poisson.h"
#include "core/surface_noise.h"
#include "render/cancel.h"
#include "render/embedded_sources.h"
#include "render/gl/batch_plan.h"
#include "render/gl/gl_api.h"
#include "render/gl/noise_window.h"
#include "render/image_buffers.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>

namespace textond::render {

using core::noise::floor_div;
using core::noise::floor_mod;

using gl::interleave_table;

namespace {

// A pass's output: 2^22 words, 64 tiles of 256^2 at 8 bits (one word a pixel), half that at 16
// bits, a third as floats. Larger windows are cut into pieces of at most kPieceSide wide.
// A software renderer (llvmpipe) takes 2^18 words a pass: a pass is where a render can stop (a
// client gone, a deadline), and at MNI 200 one 2^22-word pass took llvmpipe 20 s.
constexpr std::size_t kPassWords = std::size_t{1} << 22;
constexpr std::size_t kSoftwarePassWords = std::size_t{1} << 18;
constexpr int kPieceSide = 2048;
constexpr std::size_t kMaxCachedTables = 32;

bool is_software(const std::string& renderer) {
    for (const char* s : {"llvmpipe", "softpipe", "swrast", "Software", "SwiftShader"})
        if (renderer.find(s) != std::string::npos) return true;
    return false;
}

// Releases the context on every path out of a render.
struct CurrentScope {
    GlContext& ctx;
    bool ok;
    explicit CurrentScope(GlContext& c) : ctx(c), ok(c.make_current()) {}
    ~CurrentScope() {
        if (ok) ctx.release();
    }
};

std::string compile(const gl::GlApi& gl, GLenum type, const std::string& src, GLuint& out) {
    out = gl.CreateShader(type);
    const char* p = src.c_str();
    gl.ShaderSource(out, 1, &p, nullptr);
    gl.CompileShader(out);
    GLint ok = 0;
    gl.GetShaderiv(out, GL_COMPILE_STATUS, &ok);
    if (ok) return "";
    char log[4096] = {0};
    gl.GetShaderInfoLog(out, sizeof log, nullptr, log);
    return log;
}

Result<GLuint> link(const gl::GlApi& gl, std::initializer_list<std::pair<GLenum, std::string>> s) {
    const GLuint prog = gl.CreateProgram();
    std::vector<GLuint> shaders;
    for (const auto& [type, src] : s) {
        GLuint sh = 0;
        const std::string err = compile(gl, type, src, sh);
        shaders.push_back(sh);
        if (!err.empty()) {
            for (GLuint x : shaders) gl.DeleteShader(x);
            gl.DeleteProgram(prog);
            return make_error(ErrorCode::internal, "GLSL compile error: " + err);
        }
        gl.AttachShader(prog, sh);
    }
    gl.LinkProgram(prog);
    for (GLuint x : shaders) gl.DeleteShader(x);
    GLint ok = 0;
    gl.GetProgramiv(prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[4096] = {0};
        gl.GetProgramInfoLog(prog, sizeof log, nullptr, log);
        gl.DeleteProgram(prog);
        return make_error(ErrorCode::internal, std::string("GLSL link error: ") + log);
    }
    return prog;
}

// Textures the shaders read with texelFetch only: one level, no filtering.
void texel_fetch_only(const gl::GlApi& gl, GLenum target) {
    gl.TexParameteri(target, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(target, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.TexParameteri(target, GL_TEXTURE_MAX_LEVEL, 0);
}

void* load_proc(const char* name, void* user) {
    return static_cast<GlContext*>(user)->proc_address(name);
}

} // namespace

GlBackend::GlBackend(std::string name, std::unique_ptr<GlContext> context)
    : m_name(std::move(name)), m_context(std::move(context)), m_gl(std::make_unique<gl::GlApi>()) {}

GlBackend::~GlBackend() {
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok || !m_gl->DeleteProgram) return;
    for (const TableCache* cache : {&m_table_textures, &m_table_buffers})
        for (const auto& [key, t] : cache->entries) delete_table(*cache, t.object);
    for (auto& p : m_noise)
        if (p.id) m_gl->DeleteProgram(p.id);
    if (m_probe_program) m_gl->DeleteProgram(m_probe_program);
    if (m_surface_program) m_gl->DeleteProgram(m_surface_program);
    if (m_mesh_program) m_gl->DeleteProgram(m_mesh_program);
    if (m_vao) m_gl->DeleteVertexArrays(1, &m_vao);
    if (m_buffers[0]) m_gl->DeleteBuffers(5, m_buffers);
    for (auto& slot : m_slots) release_slot(slot);
}

void GlBackend::release_slot(Slot& slot) {
    const gl::GlApi& g = *m_gl;
    if (slot.fence) g.DeleteSync(static_cast<GLsync>(slot.fence));
    if (slot.readback) {
        g.BindBuffer(GL_COPY_WRITE_BUFFER, slot.readback);
        if (slot.mapped) g.UnmapBuffer(GL_COPY_WRITE_BUFFER);
        g.DeleteBuffers(1, &slot.readback);
    }
    if (slot.out) g.DeleteBuffers(1, &slot.out);
    if (slot.query) g.DeleteQueries(1, &slot.query);
    slot = Slot{};
}

GlslSources GlslSources::embedded() {
    return {embedded::kNoiseLib, embedded::kTextonEval, "", ""};
}

Result<std::shared_ptr<GlBackend>> GlBackend::create(std::string name,
                                                     std::unique_ptr<GlContext> context,
                                                     bool allow_software,
                                                     const GlslSources& sources) {
    std::shared_ptr<GlBackend> b(new GlBackend(std::move(name), std::move(context)));
    auto ok = b->init(allow_software, sources);
    if (!ok) return ok.error();
    return b;
}

Result<bool> GlBackend::init(bool allow_software, const GlslSources& sources) {
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok)
        return make_error(ErrorCode::unsupported, m_name + ": cannot make the context current");
    const std::string missing = m_gl->load(load_proc, m_context.get());
    if (!missing.empty())
        return make_error(ErrorCode::unsupported, m_name + ": GL function " + missing + " missing");
    const auto* r = reinterpret_cast<const char*>(m_gl->GetString(GL_RENDERER));
    const auto* v = reinterpret_cast<const char*>(m_gl->GetString(GL_VERSION));
    m_renderer = r ? r : "?";
    m_version = v ? v : "?";
    m_software = is_software(m_renderer);
    m_gl->GetIntegerv(GL_SUBPIXEL_BITS, &m_subpixel_bits);
    GLint block = 0;
    m_gl->GetIntegerv(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &block);
    if (block > 0) m_max_block_bytes = static_cast<std::size_t>(block);
    GLint shared = 0;
    m_gl->GetIntegerv(GL_MAX_COMPUTE_SHARED_MEMORY_SIZE, &shared);
    // 16 bytes a point, beside the cells' starts (1 KiB); GL guarantees 32 KiB.
    m_shared_points = std::clamp((std::max(shared, 32768) - 2048) / 16, 512, 4096);
    m_kernel = m_software ? PointKernel::host_listed : PointKernel::shared;
    if (m_software && !allow_software)
        return make_error(ErrorCode::unsupported, m_name + " found only a software renderer (" +
                                                      m_renderer + "), not a GPU");
    const std::string head = "#version 450 core\n";
    m_noise_source = sources.lib + sources.eval + embedded::kTextonNoiseComp;
    auto prog = noise_program(Precision::f32);
    if (!prog)
        return make_error(ErrorCode::unsupported,
                          m_name + " (" + m_renderer + "): " + prog.error().message);
    if (!sources.frag.empty()) {
        auto frag =
            link(*m_gl, {{GL_VERTEX_SHADER, head + sources.vert},
                         {GL_FRAGMENT_SHADER, head + sources.lib + sources.eval + sources.frag}});
        if (!frag)
            return make_error(ErrorCode::unsupported,
                              m_name + " (" + m_renderer +
                                  "), fragment entry point: " + frag.error().message);
        m_gl->DeleteProgram(frag.value());
    }
    m_gl->GenVertexArrays(1, &m_vao);
    return true;
}

std::string GlBackend::renderer() const {
    return m_name + " (" + m_renderer + ", OpenGL " + m_version + ", " + m_context->platform() +
           (m_kernel == PointKernel::shared ? ", points drawn in shared memory" : "") + ")";
}

unsigned GlBackend::cached_table(TableCache& cache, const std::shared_ptr<const LevelTable>& t) {
    auto it = cache.entries.find(t->serial);
    if (it != cache.entries.end()) return it->second.object;
    if (cache.entries.size() >= kMaxCachedTables) {
        delete_table(cache, cache.entries.begin()->second.object);
        cache.entries.erase(cache.entries.begin());
    }
    const int n = t->side(), components = cache.buffers ? 4 : 3;
    std::vector<float> texels(static_cast<std::size_t>(n) * n * components, 0.0f);
    interleave_table(*t, components, texels.data());
    const gl::GlApi& g = *m_gl;
    GLuint object = 0;
    if (cache.buffers) {
        g.GenBuffers(1, &object);
        g.BindBuffer(GL_SHADER_STORAGE_BUFFER, object);
        g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(texels.size() * 4),
                     texels.data(), GL_STATIC_DRAW);
    } else {
        g.GenTextures(1, &object);
        g.BindTexture(GL_TEXTURE_2D, object);
        g.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
        g.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, n, n, 0, GL_RGB, GL_FLOAT, texels.data());
        texel_fetch_only(g, GL_TEXTURE_2D);
    }
    cache.entries.emplace(t->serial, CachedTable{object});
    return object;
}

void GlBackend::delete_table(const TableCache& cache, unsigned object) {
    if (cache.buffers)
        m_gl->DeleteBuffers(1, &object);
    else
        m_gl->DeleteTextures(1, &object);
}

GlBackend::Work::Work() = default;
GlBackend::Work::Work(Work&&) noexcept = default;
GlBackend::Work::~Work() = default;

Result<GlBackend::NoiseProgram*> GlBackend::noise_program(Precision p) {
    NoiseProgram& np = m_noise[static_cast<int>(p)];
    if (np.id) return &np;
    const char* out = p == Precision::u8    ? "#define TEXTOND_OUT_U8\n"
                      : p == Precision::u16 ? "#define TEXTOND_OUT_U16\n"
                                            : "";
    const std::string shared = m_kernel == PointKernel::shared
                                   ? "#define TEXTOND_SHARED_POINTS " +
                                         std::to_string(m_shared_points) + "\n" +
                                         (m_mark_overflow ? "#define TEXTOND_MARK_OVERFLOW\n" : "")
                                   : std::string();
    auto prog = link(*m_gl, {{GL_COMPUTE_SHADER, std::string("#version 450 core\n") +
                                                     "#define TEXTOND_TABLE_BUFFER\n"
                                                     "#define TEXTOND_BATCH\n" +
                                                     out + shared + m_noise_source}});
    if (!prog) return prog.error();
    np.id = prog.value();
    np.tile_first = m_gl->GetUniformLocation(np.id, "u_tile_first");
    np.mask = m_gl->GetUniformLocation(np.id, "u_mask");
    return &np;
}

void GlBackend::set_point_kernel(PointKernel k, bool mark_overflow) {
    std::lock_guard<std::mutex> lock(m_mutex);
    if (k == m_kernel && mark_overflow == m_mark_overflow) return;
    CurrentScope scope(*m_context);
    for (NoiseProgram& np : m_noise)
        if (np.id) m_gl->DeleteProgram(np.id);
    for (NoiseProgram& np : m_noise) np = NoiseProgram{};
    m_kernel = k;
    m_mark_overflow = mark_overflow;
}

Result<GlBackend::Work> GlBackend::prepare(const PreparedTexton& tex, const PreparedMix* mix,
                                           const NoiseRequest& q) const {
    assert(mix ? !mix->check(q) : !tex.check(q)); // checked by the caller (backend.h)
    if (mix && q.level >= mix->level(0).limit_level())
        return make_error(ErrorCode::unsupported, m_name + ": a mix's limit levels are CPU only");
    // The GL paths hold grey or RGB (a set's whole texton, up to 8 channels, is for the CPU; the
    // server renders a set's maps, views of 1 or 3 channels).
    if (!mix && tex.channels() != 1 && tex.channels() != 3)
        return make_error(ErrorCode::unsupported,
                          m_name + ": " + std::to_string(tex.channels()) +
                              " channels (a material set's whole texton) are CPU only");
    if (!mix && tex.limit_coupled() && q.level >= tex.limit_level())
        return make_error(ErrorCode::unsupported,
                          m_name + ": a material map's limit levels are CPU only");
    Work w;
    NoiseRequest wq = q;
    if (!mix && q.marginals == Marginals::exemplar) {
        // Restored from floats, then rounded as any float render is (the same bytes as the CPU).
        w.marginals = tex.marginals(q.level);
        wq.precision = Precision::f32;
    }
    w.window = std::make_unique<gl::NoiseWindow>(
        gl::make_noise_window(tex, mix, wq, m_kernel == PointKernel::host_listed));
    w.stats.limit_model = w.window->limit_model;
    w.stats.points = 0; // not counted on the GPU
    w.stats.evaluations =
        w.window->limit_model ? static_cast<std::uint64_t>(q.width) * q.height * 25 : 0;
    return w;
}

Result<core::Image> GlBackend::render_one(const PreparedTexton& tex, const PreparedMix* mix,
                                          const NoiseRequest& q, RenderStats* stats) {
    auto w = prepare(tex, mix, q);
    if (!w) return w.error();
    render_batch({&w.value()});
    if (stats) *stats = w.value().stats;
    return std::move(w.value().image);
}

Result<core::Image> GlBackend::render(const PreparedTexton& tex, const NoiseRequest& q,
                                      RenderStats* stats) {
    return render_one(tex, nullptr, q, stats);
}

Result<core::Image> GlBackend::render_mix(const PreparedMix& mix, const NoiseRequest& q,
                                          RenderStats* stats) {
    return render_one(mix.level(0), &mix, q, stats);
}

std::vector<Result<core::Image>> GlBackend::render_many(const PreparedTexton& tex,
                                                        const std::vector<NoiseRequest>& qs,
                                                        RenderStats* stats) {
    std::vector<Result<Work>> works;
    std::vector<Work*> batch;
    works.reserve(qs.size());
    for (const auto& q : qs) {
        works.push_back(prepare(tex, nullptr, q));
        if (works.back()) batch.push_back(&works.back().value());
    }
    const double gpu_ms = render_batch(batch);
    if (stats) stats->gpu_ms = gpu_ms;
    std::vector<Result<core::Image>> out;
    out.reserve(works.size());
    for (auto& w : works)
        out.push_back(w ? std::move(w.value().image) : Result<core::Image>(w.error()));
    return out;
}

std::size_t GlBackend::pass_words() const {
    if (m_pass_words > 0) return m_pass_words;
    return m_software ? kSoftwarePassWords : kPassWords;
}

void GlBackend::set_pass_words(std::size_t words) {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_pass_words = words;
}

std::vector<double> GlBackend::last_pass_ms() {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_pass_ms;
}

namespace {
// Every window of the batch still to be answered gets `e`.
void fail_batch(const std::vector<GlBackend::Work*>& batch, const Error& e) {
    for (GlBackend::Work* w : batch)
        if (w->image) w->image = e;
}
} // namespace

double GlBackend::render_batch(const std::vector<Work*>& batch) {
    gl::BatchPlan plan = gl::plan_batch(batch, pass_words(), kPieceSide);
    if (plan.passes.empty()) return 0;
    // A storage buffer past GL_MAX_SHADER_STORAGE_BLOCK_SIZE reads zeros, silently: such a batch
    // goes as two halves (a window of the largest size lists at most 128 MiB of points).
    if (plan.points.size() * 4 > m_max_block_bytes) {
        if (batch.size() == 1) {
            fail_batch(batch, Error{ErrorCode::too_large,
                                    m_name + ": the window lists more points than a GL storage "
                                             "buffer holds"});
            return 0;
        }
        for (Work* w : batch)
            if (w->image) recycle_image(std::move(w->image.value()));
        const auto half = static_cast<std::ptrdiff_t>(batch.size() / 2);
        return render_batch({batch.begin(), batch.begin() + half}) +
               render_batch({batch.begin() + half, batch.end()});
    }
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok) {
        fail_batch(batch, Error{ErrorCode::internal, m_name + ": cannot make context current"});
        return 0;
    }
    m_pass_ms.clear();
    if (auto e = map_slots()) {
        fail_batch(batch, *e);
        return 0;
    }
    upload(0, plan.starts.data(), plan.starts.size() * 4);
    upload(1, plan.points.data(), plan.points.size() * 4);
    upload(3, plan.records.data(), plan.records.size() * 4);
    upload(4, plan.thresholds.data(), plan.thresholds.size() * 4);
    const double gpu_ms = run_passes(plan, batch);
    for (Work* w : batch) {
        if (w->image && stopped(w->window->cancel))
            w->image = abandoned(w->window->cancel, "the render");
        if (w->image && w->marginals) restore_marginals(*w->marginals, w->image.value());
    }
    return gpu_ms;
}

// The two output buffers a pass writes and their persistently mapped readback copies, made once.
std::optional<Error> GlBackend::map_slots() {
    const gl::GlApi& g = *m_gl;
    const std::size_t words = pass_words();
    if (m_slot_words != words)
        for (Slot& slot : m_slots) release_slot(slot);
    m_slot_words = words;
    for (Slot& slot : m_slots) {
        if (slot.mapped) continue;
        const auto bytes = static_cast<GLsizeiptr>(words * 4);
        release_slot(slot); // a failed attempt's
        g.GenBuffers(1, &slot.out);
        g.BindBuffer(GL_SHADER_STORAGE_BUFFER, slot.out);
        g.BufferData(GL_SHADER_STORAGE_BUFFER, bytes, nullptr, GL_DYNAMIC_COPY);
        g.GenBuffers(1, &slot.readback);
        g.BindBuffer(GL_COPY_WRITE_BUFFER, slot.readback);
        const GLbitfield map = GL_MAP_READ_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
        g.BufferStorage(GL_COPY_WRITE_BUFFER, bytes, nullptr, map | GL_CLIENT_STORAGE_BIT);
        slot.mapped = static_cast<const std::uint32_t*>(
            g.MapBufferRange(GL_COPY_WRITE_BUFFER, 0, bytes, map));
        g.GenQueries(1, &slot.query);
        if (!slot.mapped) {
            const GLenum err = g.GetError();
            release_slot(slot);
            return Error{ErrorCode::internal, m_name + ": cannot map a readback buffer (GL error " +
                                                  std::to_string(static_cast<int>(err)) + ")"};
        }
    }
    return std::nullopt;
}

// Two passes in flight: pass k computes into slot k % 2 while pass k - 1 is copied back, each
// fenced. A pass none of whose windows is still wanted is skipped.
double GlBackend::run_passes(const gl::BatchPlan& plan, const std::vector<Work*>& batch) {
    const gl::GlApi& g = *m_gl;
    std::vector<GLuint> masks;
    const gl::Pass* in_flight[2] = {nullptr, nullptr};
    double gpu_ms = 0;
    std::optional<Error> failed;
    auto finish = [&](int s) {
        if (in_flight[s] && !failed) failed = finish_pass(s, *in_flight[s], gpu_ms);
        in_flight[s] = nullptr;
    };
    const auto& passes = plan.passes;
    for (std::size_t k = 0; k < passes.size() && !failed; ++k) {
        const int s = static_cast<int>(k % 2);
        finish(s);
        if (failed) break;
        bool wanted = false;
        for (const gl::Piece& p : passes[k].pieces)
            wanted = wanted || !stopped(p.work->window->cancel);
        if (!wanted) continue;
        if (auto e = dispatch_pass(passes[k], s, plan, masks)) {
            failed = e;
            break;
        }
        in_flight[s] = &passes[k];
    }
    finish(static_cast<int>(passes.size() % 2)); // the older of the two in flight first
    finish(static_cast<int>((passes.size() + 1) % 2));
    if (!masks.empty()) g.DeleteTextures(static_cast<GLsizei>(masks.size()), masks.data());
    const GLenum err = g.GetError();
    if (failed)
        fail_batch(batch, *failed);
    else if (err != GL_NO_ERROR)
        fail_batch(batch, Error{ErrorCode::internal,
                                m_name + ": GL error " + std::to_string(static_cast<int>(err))});
    return gpu_ms;
}

// One pass into slot `s`: a dispatch per run of pieces of one table (a mix uploads its tables
// and mask first), timed, then copied into the slot's readback buffer behind a fence.
std::optional<Error> GlBackend::dispatch_pass(const gl::Pass& pass, int s,
                                              const gl::BatchPlan& plan,
                                              std::vector<unsigned>& masks) {
    const gl::GlApi& g = *m_gl;
    auto prog = noise_program(pass.precision);
    if (!prog) return prog.error();
    g.UseProgram(prog.value()->id);
    g.Uniform1i(prog.value()->mask, 3); // a unit of its own (two sampler types on one fail)
    Slot& slot = m_slots[s];
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, slot.out);
    const auto host_start = std::chrono::steady_clock::now();
    slot.dispatched = host_start;
    g.BeginQuery(GL_TIME_ELAPSED, slot.query);
    for (std::size_t i = 0; i < pass.pieces.size();) {
        std::size_t j = i;
        int gx = 0, gy = 0;
        for (; j < pass.pieces.size() && pass.pieces[j].key == pass.pieces[i].key; ++j) {
            gx = std::max(gx, (pass.pieces[j].w + 15) / 16);
            gy = std::max(gy, (pass.pieces[j].h + 15) / 16);
        }
        const gl::NoiseWindow& win = *pass.pieces[i].work->window;
        if (!win.mix_tables.empty()) {
            upload(2, win.mix_tables.data(), win.mix_tables.size() * 4);
            if (win.mask) {
                GLuint tex = 0;
                g.ActiveTexture(GL_TEXTURE3);
                g.GenTextures(1, &tex);
                g.BindTexture(GL_TEXTURE_2D, tex);
                g.TexImage2D(GL_TEXTURE_2D, 0, GL_R32F, win.mask->mask.width, win.mask->mask.height,
                             0, GL_RED, GL_FLOAT, win.mask->mask.data.data());
                texel_fetch_only(g, GL_TEXTURE_2D);
                masks.push_back(tex);
            }
        } else if (win.table) {
            g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cached_table(m_table_buffers, win.table));
        } else {
            upload(2, plan.thresholds.data(), 16); // the limit model reads no table
        }
        g.Uniform1i(prog.value()->tile_first, static_cast<GLint>(pass.first_record + i));
        g.DispatchCompute(static_cast<GLuint>(gx), static_cast<GLuint>(gy),
                          static_cast<GLuint>(j - i));
        i = j;
    }
    g.EndQuery(GL_TIME_ELAPSED);
    g.MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    // llvmpipe's timer queries time only rasterised scenes, not compute: there the "GPU" is
    // this CPU, and the dispatches run inside the calls, so the host clock times them.
    slot.host_ms = m_software ? std::chrono::duration<double, std::milli>(
                                    std::chrono::steady_clock::now() - host_start)
                                    .count()
                              : -1;
    g.BindBuffer(GL_COPY_READ_BUFFER, slot.out);
    g.BindBuffer(GL_COPY_WRITE_BUFFER, slot.readback);
    g.CopyBufferSubData(
        GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, 0, 0,
        static_cast<GLsizeiptr>(pass.pixels * 4 *
                                static_cast<std::size_t>(gl::words_per_pixel(pass.precision))));
    slot.fence = g.FenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    return std::nullopt;
}

// Waits for the pass in slot `s`, adds its GPU time to its windows' and the batch's, and copies
// it into its windows.
std::optional<Error> GlBackend::finish_pass(int s, const gl::Pass& pass, double& gpu_ms) {
    const gl::GlApi& g = *m_gl;
    Slot& slot = m_slots[s];
    auto fence = static_cast<GLsync>(slot.fence);
    // Polled, never waited on in the driver (render/gl/fence_wait.h); the first poll flushes.
    // TEXTOND_GL_WAIT=driver waits in the driver as before, for tests/gpu/device_check.sh to
    // measure the two in one run.
    static const bool in_driver = [] {
        const char* how = std::getenv("TEXTOND_GL_WAIT");
        return how && std::string(how) == "driver";
    }();
    const auto since = std::chrono::duration_cast<std::chrono::microseconds>(
        std::chrono::steady_clock::now() - slot.dispatched);
    const gl::FenceWait wait = gl::await_fence(
        [&] {
            const GLenum r =
                g.ClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT, in_driver ? 1000000000ull : 0);
            if (r == GL_WAIT_FAILED) return gl::FenceState::failed;
            return r == GL_TIMEOUT_EXPIRED ? gl::FenceState::pending : gl::FenceState::signalled;
        },
        m_pass_time.of(pass.pixels) - since,
        [](std::chrono::microseconds d) { std::this_thread::sleep_for(d); });
    g.DeleteSync(fence);
    slot.fence = nullptr;
    if (wait.state == gl::FenceState::failed)
        return Error{ErrorCode::internal, m_name + ": waiting for a pass failed"};
    GLuint64 ns = 0;
    g.GetQueryObjectui64v(slot.query, GL_QUERY_RESULT, &ns);
    const double pass_ms = slot.host_ms >= 0 ? slot.host_ms : static_cast<double>(ns) * 1e-6;
    if (slot.host_ms < 0) m_pass_time.measured(pass_ms, pass.pixels);
    gpu_ms += pass_ms;
    m_pass_ms.push_back(pass_ms);
    std::map<Work*, bool> seen;
    for (const gl::Piece& p : pass.pieces) {
        if (!seen[p.work]) p.work->stats.gpu_ms = std::max(0.0, p.work->stats.gpu_ms) + pass_ms;
        seen[p.work] = true;
    }
    gl::copy_out_pass(pass, slot.mapped);
    return std::nullopt;
}

void GlBackend::upload(int k, const void* data, std::size_t bytes) {
    const gl::GlApi& g = *m_gl;
    if (!m_buffers[0]) g.GenBuffers(5, m_buffers);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, m_buffers[k]);
    if (bytes > m_capacity[k]) {
        m_capacity[k] = std::max(bytes, 2 * m_capacity[k]);
        g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(m_capacity[k]), nullptr,
                     GL_DYNAMIC_DRAW);
    }
    g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(bytes), data);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, static_cast<GLuint>(1 + k), m_buffers[k]);
}

Result<std::vector<float>> GlBackend::surface(const PreparedTexton& tex, std::uint64_t seed,
                                              double mni, const std::vector<double>& y,
                                              const std::vector<float>& normals) {
    const std::size_t n = y.size() / 3;
    if (y.size() != normals.size() || y.size() % 3 != 0)
        return make_error(ErrorCode::invalid_argument, "surface: points and normals differ");
    std::vector<std::uint32_t> in(n * 12, 0);
    for (std::size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d) {
            const double v = y[3 * i + static_cast<std::size_t>(d)];
            const double fl = std::floor(v);
            if (!(std::fabs(fl) < 2147483000.0))
                return make_error(ErrorCode::invalid_argument, "surface: |y| over 2^31 texels");
            const auto whole = static_cast<std::int32_t>(fl);
            const auto frac = static_cast<float>(v - fl);
            in[12 * i + static_cast<std::size_t>(d)] = static_cast<std::uint32_t>(whole);
            std::memcpy(&in[12 * i + 3 + static_cast<std::size_t>(d)], &frac, 4);
            std::memcpy(&in[12 * i + 6 + static_cast<std::size_t>(d)],
                        &normals[3 * i + static_cast<std::size_t>(d)], 4);
        }
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok) return make_error(ErrorCode::internal, m_name + ": cannot make context current");
    const gl::GlApi& g = *m_gl;
    if (!m_surface_program) {
        auto prog =
            link(g, {{GL_COMPUTE_SHADER, std::string("#version 450 core\n") + embedded::kNoiseLib +
                                             embedded::kSurfaceLib + embedded::kSurfaceNoiseComp}});
        if (!prog) return prog.error();
        m_surface_program = prog.value();
    }
    g.UseProgram(m_surface_program);
    set_surface_uniforms(m_surface_program, tex, seed, mni);
    g.Uniform1i(g.GetUniformLocation(m_surface_program, "u_count"), static_cast<GLint>(n));
    GLuint bufs[2];
    g.GenBuffers(2, bufs);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[0]);
    g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(in.size() * 4), in.data(),
                 GL_STATIC_DRAW);
    std::vector<float> out(n * 4, 0.0f);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[1]);
    g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(out.size() * 4), out.data(),
                 GL_DYNAMIC_READ);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, bufs[0]);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bufs[1]);
    g.DispatchCompute(static_cast<GLuint>((n + 63) / 64), 1, 1);
    g.MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[1]);
    g.GetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(out.size() * 4),
                       out.data());
    g.DeleteBuffers(2, bufs);
    if (g.GetError() != GL_NO_ERROR) return make_error(ErrorCode::internal, "surface: GL error");
    std::vector<float> rgb(n * 3);
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            rgb[3 * i + static_cast<std::size_t>(c)] = out[4 * i + static_cast<std::size_t>(c)];
    return rgb;
}

void GlBackend::set_surface_uniforms(unsigned prog, const PreparedTexton& tex, std::uint64_t seed,
                                     double mni) {
    const gl::GlApi& g = *m_gl;
    const auto table = tex.table(0);
    // The surface noise's own constants (cell size, thresholds, normalisation), as the CPU's.
    const core::SurfaceNoise noise(tex.texton(), mni);
    const std::vector<std::uint32_t>& thresholds = noise.thresholds();
    auto loc = [&](const char* name) { return g.GetUniformLocation(prog, name); };
    g.ActiveTexture(GL_TEXTURE0);
    g.BindTexture(GL_TEXTURE_2D, cached_table(m_table_textures, table));
    g.Uniform1i(loc("u_table"), 0);
    g.Uniform1i(loc("u_pad"), table->pad);
    g.Uniform1i(loc("u_r"), tex.size());
    g.Uniform1i(loc("u_order"), tex.order());
    g.Uniform1i(loc("u_a"), noise.cell_size());
    g.Uniform2ui(loc("u_seed"), static_cast<GLuint>(seed), static_cast<GLuint>(seed >> 32));
    g.Uniform1f(loc("u_norm"), static_cast<float>(noise.norm()));
    const auto& m = tex.texton().mean;
    const bool grey = tex.channels() == 1;
    g.Uniform3f(loc("u_mean"), static_cast<float>(m[0]), static_cast<float>(grey ? 0 : m[1]),
                static_cast<float>(grey ? 0 : m[2]));
    g.Uniform1uiv(loc("u_thresholds[0]"), static_cast<GLsizei>(thresholds.size()),
                  thresholds.data());
    g.Uniform1i(loc("u_nthresholds"), static_cast<GLint>(thresholds.size()));
}

Result<core::Image> GlBackend::mesh_preview(const PreparedTexton& tex, std::uint64_t seed,
                                            double mni, const core::TriangleMesh& mesh,
                                            const MeshView& view, int width, int height) {
    core::TriangleMesh normals_mesh;
    const core::TriangleMesh* m = &mesh;
    if (mesh.normals.size() != mesh.positions.size()) {
        normals_mesh = mesh;
        core::smooth_normals(normals_mesh);
        m = &normals_mesh;
    }
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok) return make_error(ErrorCode::internal, m_name + ": cannot make context current");
    const gl::GlApi& g = *m_gl;
    if (!m_mesh_program) {
        const std::string head = "#version 450 core\n";
        auto prog =
            link(g, {{GL_VERTEX_SHADER, head + embedded::kMeshPreviewVert},
                     {GL_FRAGMENT_SHADER, head + embedded::kNoiseLib + embedded::kSurfaceLib +
                                              embedded::kMeshPreviewFrag}});
        if (!prog) return prog.error();
        m_mesh_program = prog.value();
    }
    const GLuint prog = m_mesh_program;
    g.UseProgram(prog);
    set_surface_uniforms(prog, tex, seed, mni);
    auto loc = [&](const char* name) { return g.GetUniformLocation(prog, name); };
    const auto mvp = view.mvp();
    g.UniformMatrix4fv(loc("u_mvp"), 1, GL_TRUE, mvp.data());
    g.Uniform1f(loc("u_scale"), static_cast<float>(view.scale));
    g.Uniform3f(loc("u_fwd"), static_cast<float>(view.fwd[0]), static_cast<float>(view.fwd[1]),
                static_cast<float>(view.fwd[2]));
    g.Uniform3f(loc("u_light"), static_cast<float>(view.light[0]),
                static_cast<float>(view.light[1]), static_cast<float>(view.light[2]));
    g.Uniform1i(loc("u_grey"), tex.channels() == 1 ? 1 : 0);

    GLuint vao = 0, bufs[3] = {0, 0, 0}, target = 0, depth = 0, fbo = 0;
    g.GenVertexArrays(1, &vao);
    g.BindVertexArray(vao);
    g.GenBuffers(3, bufs);
    g.BindBuffer(GL_ARRAY_BUFFER, bufs[0]);
    g.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m->positions.size() * 4),
                 m->positions.data(), GL_STATIC_DRAW);
    g.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    g.EnableVertexAttribArray(0);
    g.BindBuffer(GL_ARRAY_BUFFER, bufs[1]);
    g.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m->normals.size() * 4), m->normals.data(),
                 GL_STATIC_DRAW);
    g.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    g.EnableVertexAttribArray(1);
    g.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, bufs[2]);
    g.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(m->triangles.size() * 4),
                 m->triangles.data(), GL_STATIC_DRAW);

    g.ActiveTexture(GL_TEXTURE1); // unit 0 holds the table
    g.GenTextures(1, &target);
    g.BindTexture(GL_TEXTURE_2D, target);
    g.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT, nullptr);
    g.GenRenderbuffers(1, &depth);
    g.BindRenderbuffer(GL_RENDERBUFFER, depth);
    g.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
    g.GenFramebuffers(1, &fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target, 0);
    g.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    core::Image out;
    bool complete = g.CheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    if (complete) {
        g.Viewport(0, 0, width, height);
        g.Enable(GL_DEPTH_TEST);
        g.ClearColor(0, 0, 0, 0);
        g.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        g.DrawElements(GL_TRIANGLES, static_cast<GLsizei>(m->triangles.size()), GL_UNSIGNED_INT,
                       nullptr);
        std::vector<float> rgba(static_cast<std::size_t>(width) * height * 4);
        g.PixelStorei(GL_PACK_ALIGNMENT, 4);
        g.ReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, rgba.data());
        out = core::Image(width, height, 4);
        for (int y = 0; y < height; ++y) // GL's first row is the bottom one
            for (int x = 0; x < width; ++x)
                for (int c = 0; c < 4; ++c)
                    out.at(c, x, height - 1 - y) =
                        rgba[(static_cast<std::size_t>(y) * width + x) * 4 +
                             static_cast<std::size_t>(c)];
        g.Disable(GL_DEPTH_TEST);
    }
    const GLenum err = g.GetError();
    g.BindFramebuffer(GL_FRAMEBUFFER, 0);
    g.DeleteFramebuffers(1, &fbo);
    g.DeleteRenderbuffers(1, &depth);
    g.DeleteTextures(1, &target);
    g.DeleteBuffers(3, bufs);
    g.BindVertexArray(m_vao);
    g.DeleteVertexArrays(1, &vao);
    if (!complete) return make_error(ErrorCode::internal, m_name + ": mesh framebuffer incomplete");
    if (err != GL_NO_ERROR)
        return make_error(ErrorCode::internal,
                          m_name + ": GL error " + std::to_string(static_cast<int>(err)));
    return out;
}

Result<std::vector<std::uint32_t>> GlBackend::probe(const std::vector<std::uint32_t>& queries,
                                                    const std::vector<std::uint32_t>& thresholds) {
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok) return make_error(ErrorCode::internal, m_name + ": cannot make context current");
    const gl::GlApi& g = *m_gl;
    if (!m_probe_program) {
        auto prog =
            link(g, {{GL_COMPUTE_SHADER, std::string("#version 450 core\n") + embedded::kNoiseLib +
                                             embedded::kSpecProbeComp}});
        if (!prog) return prog.error();
        m_probe_program = prog.value();
    }
    const std::size_t n = queries.size() / 8;
    g.UseProgram(m_probe_program);
    const GLint lt = g.GetUniformLocation(m_probe_program, "u_thresholds[0]");
    g.Uniform1uiv(lt, static_cast<GLsizei>(thresholds.size()), thresholds.data());
    g.Uniform1i(g.GetUniformLocation(m_probe_program, "u_nthresholds"),
                static_cast<int>(thresholds.size()));
    GLuint bufs[2];
    g.GenBuffers(2, bufs);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[0]);
    g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(queries.size() * 4),
                 queries.data(), GL_STATIC_DRAW);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[1]);
    std::vector<std::uint32_t> out(n * 64, 0);
    g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(out.size() * 4), out.data(),
                 GL_DYNAMIC_READ);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, bufs[0]);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bufs[1]);
    g.DispatchCompute(static_cast<GLuint>(n), 1, 1);
    g.MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, bufs[1]);
    g.GetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(out.size() * 4),
                       out.data());
    g.DeleteBuffers(2, bufs);
    if (g.GetError() != GL_NO_ERROR) return make_error(ErrorCode::internal, "probe: GL error");
    return out;
}

} // namespace textond::render
