#include "render/gl/gl_backend.h"

#include "core/grid_poisson.h"
#include "core/surface_noise.h"
#include "render/cancel.h"
#include "render/gl/gl_api.h"
#include "render/gl/glsl_sources.h"
#include "render/image_buffers.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace textond::render {

using core::noise::floor_div;
using core::noise::floor_mod;

namespace {

constexpr int kChunk = 2048; // framebuffer side: big windows are drawn in chunks
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

// A level table as `components` floats a texel, row by row (G[y][x], zeros past its channels):
// the layout of the RGB32F textures and of the vec4 storage buffers.
void interleave_table(const LevelTable& t, int components, float* out) {
    const int n = t.side();
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            for (int c = 0; c < t.channels; ++c)
                out[(static_cast<std::size_t>(y) * n + x) * components + c] = t.row(c, y)[x];
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
    for (auto& [key, t] : m_tables) m_gl->DeleteTextures(1, &t.texture);
    for (auto& [key, t] : m_table_buffers) m_gl->DeleteBuffers(1, &t.texture);
    if (m_program) m_gl->DeleteProgram(m_program);
    if (m_probe_program) m_gl->DeleteProgram(m_probe_program);
    if (m_surface_program) m_gl->DeleteProgram(m_surface_program);
    if (m_mesh_program) m_gl->DeleteProgram(m_mesh_program);
    if (m_vao) m_gl->DeleteVertexArrays(1, &m_vao);
    if (m_out_fbo) m_gl->DeleteFramebuffers(1, &m_out_fbo);
    if (m_point_buffers[0]) m_gl->DeleteBuffers(3, m_point_buffers);
    if (m_out_texture) m_gl->DeleteTextures(1, &m_out_texture);
    if (m_timer) m_gl->DeleteQueries(1, &m_timer);
}

GlslSources GlslSources::embedded() {
    return {glsl::kNoiseLib, glsl::kTextonEval, "", ""};
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
    if (m_software && !allow_software)
        return make_error(ErrorCode::unsupported, m_name + " found only a software renderer (" +
                                                      m_renderer + "), not a GPU");
    const std::string head = "#version 450 core\n";
    auto prog =
        link(*m_gl, {{GL_COMPUTE_SHADER, head + "#define TEXTOND_TABLE_BUFFER\n" + sources.lib +
                                             sources.eval + glsl::kTextonNoiseComp}});
    if (!prog)
        return make_error(ErrorCode::unsupported,
                          m_name + " (" + m_renderer + "): " + prog.error().message);
    m_program = prog.value();
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
           ")";
}

int GlBackend::uniform(const char* name) {
    auto it = m_uniforms.find(name);
    if (it != m_uniforms.end()) return it->second;
    const int loc = m_gl->GetUniformLocation(m_program, name);
    m_uniforms.emplace(name, loc);
    return loc;
}

unsigned GlBackend::table_buffer(const std::shared_ptr<const LevelTable>& t) {
    auto it = m_table_buffers.find(t.get());
    if (it != m_table_buffers.end()) return it->second.texture;
    if (m_table_buffers.size() >= kMaxCachedTables) {
        m_gl->DeleteBuffers(1, &m_table_buffers.begin()->second.texture);
        m_table_buffers.erase(m_table_buffers.begin());
    }
    const int n = t->side();
    std::vector<float> texels(static_cast<std::size_t>(n) * n * 4, 0.0f);
    interleave_table(*t, 4, texels.data());
    GLuint buf = 0;
    m_gl->GenBuffers(1, &buf);
    m_gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, buf);
    m_gl->BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(texels.size() * 4),
                     texels.data(), GL_STATIC_DRAW);
    m_table_buffers.emplace(t.get(), CachedTable{t, buf});
    return buf;
}

unsigned GlBackend::table_texture(const std::shared_ptr<const LevelTable>& t) {
    auto it = m_tables.find(t.get());
    if (it != m_tables.end()) return it->second.texture;
    if (m_tables.size() >= kMaxCachedTables) {
        m_gl->DeleteTextures(1, &m_tables.begin()->second.texture);
        m_tables.erase(m_tables.begin());
    }
    const int n = t->side();
    std::vector<float> texels(static_cast<std::size_t>(n) * n * 3, 0.0f);
    interleave_table(*t, 3, texels.data());
    GLuint tex = 0;
    m_gl->GenTextures(1, &tex);
    m_gl->BindTexture(GL_TEXTURE_2D, tex);
    m_gl->PixelStorei(GL_UNPACK_ALIGNMENT, 4);
    m_gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, n, n, 0, GL_RGB, GL_FLOAT, texels.data());
    texel_fetch_only(*m_gl, GL_TEXTURE_2D);
    m_tables.emplace(t.get(), CachedTable{t, tex});
    return tex;
}

Result<core::Image> GlBackend::render(const PreparedTexton& tex, const NoiseRequest& q,
                                      RenderStats* stats) {
    if (auto err = tex.check(q)) return *err;
    return render_impl(tex, nullptr, q, stats);
}

Result<core::Image> GlBackend::render_mix(const PreparedMix& mix, const NoiseRequest& q,
                                          RenderStats* stats) {
    if (auto err = mix.check(q)) return *err;
    if (q.level >= mix.level(0).limit_level())
        return make_error(ErrorCode::unsupported, m_name + ": a mix's limit levels are CPU only");
    return render_impl(mix.level(0), &mix, q, stats);
}

Result<core::Image> GlBackend::render_impl(const PreparedTexton& tex, const PreparedMix* mix,
                                           const NoiseRequest& q, RenderStats* stats) {
    std::lock_guard<std::mutex> lock(m_mutex);
    CurrentScope scope(*m_context);
    if (!scope.ok) return make_error(ErrorCode::internal, m_name + ": cannot make context current");
    const gl::GlApi& g = *m_gl;
    g.UseProgram(m_program);

    const bool limit = q.level >= tex.limit_level();
    const int nc = tex.channels();
    GLuint mix_mask = 0; // this render's only
    // The mask sampler on a unit of its own (two sampler types on one unit fail a dispatch).
    g.Uniform1i(uniform("u_mask"), 3);
    g.Uniform1i(uniform("u_mix"), 0);
    const auto& mean = tex.texton().mean;
    g.Uniform1i(uniform("u_mode"), limit ? 1 : 0);
    g.Uniform1i(uniform("u_level"), q.level);
    g.Uniform1i(uniform("u_channels"), nc);
    g.Uniform2ui(uniform("u_seed"), static_cast<GLuint>(q.seed), static_cast<GLuint>(q.seed >> 32));
    g.Uniform3f(uniform("u_mean"), static_cast<float>(mean[0]),
                static_cast<float>(nc == 3 ? mean[1] : mean[0]),
                static_cast<float>(nc == 3 ? mean[2] : mean[0]));
    auto u64 = [&](const char* name, std::int64_t v) {
        const auto u = static_cast<std::uint64_t>(v);
        g.Uniform2ui(uniform(name), static_cast<GLuint>(u), static_cast<GLuint>(u >> 32));
    };
    if (limit) {
        const auto& lm = tex.limit(q.level);
        float kappa[25], a[9] = {0};
        for (int i = 0; i < 25; ++i)
            kappa[i] = static_cast<float>(lm.kappa[static_cast<std::size_t>(i)]);
        for (int c = 0; c < nc; ++c)
            for (int d = 0; d < nc; ++d) a[c * 3 + d] = static_cast<float>(lm.a(c, d));
        g.Uniform1fv(uniform("u_kappa[0]"), 25, kappa);
        g.UniformMatrix3fv(uniform("u_A"), 1, GL_TRUE, a); // row-major rows of A
        u64("u_q0x", q.x0 - 2);
        u64("u_q0y", q.y0 - 2);
        if (stats) {
            stats->limit_model = true;
            stats->points = 0;
            stats->evaluations = static_cast<std::uint64_t>(q.width) * q.height * 25;
        }
    } else {
        const auto table = tex.table(q.level);
        const core::noise::GridPoisson grid(tex.size(), q.mni, q.period);
        const int r = tex.size(), a = grid.a;
        const std::int64_t st = q.level > 0 ? std::int64_t{1} << q.level : 1;
        const int sub_log2 = q.level < 0 ? -q.level : 0;
        // The base cell makes every relative cell and position in the shader non-negative.
        const int reach = tex.order() == 3 ? 1 : 0;
        auto base = [&](std::int64_t p0, std::int64_t& cell, int& origin) {
            if (q.level >= 0) {
                cell = floor_div(st * p0 - r - reach, a);
                origin = static_cast<int>(st * p0 - cell * a);
            } else {
                cell = floor_div(floor_div(p0, std::int64_t{1} << sub_log2) - r - 1 - reach, a);
                origin = static_cast<int>(p0 - (cell * a << sub_log2));
            }
        };
        std::int64_t bcx, bcy;
        int ox, oy;
        base(q.x0, bcx, ox);
        base(q.y0, bcy, oy);
        g.Uniform1i(uniform("u_side"), table->side());
        if (!mix) g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, table_buffer(table));
        g.Uniform1i(uniform("u_st"), static_cast<int>(st));
        g.Uniform1i(uniform("u_sub_log2"), sub_log2);
        g.Uniform1i(uniform("u_L"), table->length);
        g.Uniform1i(uniform("u_r"), r);
        g.Uniform1i(uniform("u_order"), tex.order());
        g.Uniform1i(uniform("u_a"), a);
        u64("u_base_cx", bcx);
        u64("u_base_cy", bcy);
        const bool tileable = q.period[0] > 0;
        g.Uniform2i(uniform("u_period"), tileable ? static_cast<int>(q.period[0]) : 0,
                    tileable ? static_cast<int>(q.period[1]) : 0);
        g.Uniform2i(uniform("u_base_mod"),
                    tileable ? static_cast<int>(floor_mod(bcx, q.period[0])) : 0,
                    tileable ? static_cast<int>(floor_mod(bcy, q.period[1])) : 0);
        g.Uniform2i(uniform("u_origin"), ox, oy);
        // The window's cells from the base cell: up to the last pixel's reach (the shader's
        // reach_cells, in the same integers).
        auto last_cell = [&](int origin, int n) -> std::int64_t {
            if (q.level >= 0) return (origin + std::int64_t{n - 1} * st + st - 1 + reach) / a;
            return (((origin + std::int64_t{n - 1}) >> sub_log2) + 1 + reach) / a;
        };
        const std::int64_t ncx = last_cell(ox, q.width) + 1, ncy = last_cell(oy, q.height) + 1;
        // Listing the window's points pays while there are far fewer of them than pixels
        // (levels <= 1); above, each pixel regenerates its own.
        const bool listed = static_cast<double>(ncx) * static_cast<double>(ncy) * grid.mu <=
                            std::max(65536.0, static_cast<double>(q.width) * q.height / 8);
        g.Uniform1i(uniform("u_list"), listed ? 1 : 0);
        if (listed) {
            // Rows of cells in parallel, then one run: cells by y then x, points in draw order.
            std::vector<std::vector<std::uint32_t>> rows(static_cast<std::size_t>(ncy));
            std::vector<std::uint32_t> counts(static_cast<std::size_t>(ncx * ncy));
#pragma omp parallel for schedule(dynamic)
            for (std::int64_t cy = 0; cy < ncy; ++cy) {
                std::vector<core::noise::CellPoint> pts;
                auto& row = rows[static_cast<std::size_t>(cy)];
                for (std::int64_t cx = 0; cx < ncx; ++cx) {
                    const int n = grid.cell_points(q.seed, bcx + cx, bcy + cy, pts);
                    counts[static_cast<std::size_t>(cy * ncx + cx)] = static_cast<std::uint32_t>(n);
                }
                row.reserve(pts.size() * 4);
                for (const auto& p : pts) {
                    const int layer =
                        mix ? mix->level_at(static_cast<double>(p.bx) + p.fx / 16777216.0,
                                            static_cast<double>(p.by) + p.fy / 16777216.0)
                            : 0;
                    row.push_back(static_cast<std::uint32_t>(p.bx - bcx * a));
                    row.push_back(static_cast<std::uint32_t>(p.by - bcy * a));
                    row.push_back(p.fx | (p.eps < 0 ? 0x80000000u : 0u));
                    row.push_back(p.fy | (static_cast<std::uint32_t>(layer) << 24));
                }
            }
            std::vector<std::uint32_t> starts(counts.size() + 1, 0), points;
            for (std::size_t i = 0; i < counts.size(); ++i) starts[i + 1] = starts[i] + counts[i];
            points.reserve(static_cast<std::size_t>(starts.back()) * 4 + 4);
            for (const auto& row : rows) points.insert(points.end(), row.begin(), row.end());
            if (points.empty()) points.assign(4, 0); // a buffer may not be empty
            upload_points(0, starts.data(), starts.size() * 4);
            upload_points(1, points.data(), points.size() * 4);
            g.Uniform2i(uniform("u_cells"), static_cast<int>(ncx), static_cast<int>(ncy));
        } else {
            const std::uint32_t none[4] = {0, 0, 0, 0}; // every binding the program names is bound
            upload_points(0, none, sizeof none);
            upload_points(1, none, sizeof none);
        }
        g.Uniform1f(uniform("u_scale"), static_cast<float>(1.0 / std::sqrt(grid.lambda)));
        g.Uniform1uiv(uniform("u_thresholds[0]"), static_cast<GLsizei>(grid.thresholds.size()),
                      grid.thresholds.data());
        g.Uniform1i(uniform("u_nthresholds"), static_cast<int>(grid.thresholds.size()));
        g.Uniform1i(uniform("u_mix"), mix ? 1 : 0);
        if (mix) {
            // All level tables as one array, and the field as an affine map (or a mask) of the
            // position relative to the base cell's origin (NOISE_SPEC.md section 9).
            const int side = table->side(), nl = mix->levels();
            const std::size_t layer = static_cast<std::size_t>(side) * side * 4;
            std::vector<float> texels(layer * static_cast<std::size_t>(nl), 0.0f);
            for (int l = 0; l < nl; ++l)
                interleave_table(*mix->level(l).table(q.level), 4,
                                 texels.data() + layer * static_cast<std::size_t>(l));
            upload_points(2, texels.data(), texels.size() * 4); // binding 3, as one texton's
            const core::MixField& f = mix->field();
            const double bx = static_cast<double>(bcx) * a, by = static_cast<double>(bcy) * a;
            g.Uniform1i(uniform("u_nlevels"), nl);
            g.Uniform1i(uniform("u_field"), f.kind == core::MixField::Kind::ramp ? 0 : 1);
            if (f.kind == core::MixField::Kind::ramp) {
                const double n = std::hypot(f.dx, f.dy) * f.width;
                g.Uniform2f(uniform("u_rho_g"), static_cast<float>(f.dx / n),
                            static_cast<float>(f.dy / n));
                g.Uniform1f(uniform("u_rho_c"),
                            static_cast<float>(((bx - f.x0) * f.dx + (by - f.y0) * f.dy) / n));
            } else {
                g.ActiveTexture(GL_TEXTURE3);
                g.GenTextures(1, &mix_mask);
                g.BindTexture(GL_TEXTURE_2D, mix_mask);
                g.TexImage2D(GL_TEXTURE_2D, 0, GL_R32F, f.mask.width, f.mask.height, 0, GL_RED,
                             GL_FLOAT, f.mask.data.data());
                texel_fetch_only(g, GL_TEXTURE_2D);
                g.Uniform1f(uniform("u_mask_inv_scale"), static_cast<float>(1.0 / f.scale));
                g.Uniform2f(uniform("u_mask_o"), static_cast<float>((bx - f.x0) / f.scale),
                            static_cast<float>((by - f.y0) / f.scale));
            }
            const auto& mu = mix->level(0).texton().mean;
            const auto& mv = mix->level(nl - 1).texton().mean;
            const bool grey = nc == 1;
            g.Uniform3f(uniform("u_mean_u"), static_cast<float>(mu[0]),
                        static_cast<float>(grey ? mu[0] : mu[1]),
                        static_cast<float>(grey ? mu[0] : mu[2]));
            g.Uniform3f(uniform("u_mean_v"), static_cast<float>(mv[0]),
                        static_cast<float>(grey ? mv[0] : mv[1]),
                        static_cast<float>(grey ? mv[0] : mv[2]));
        }
        if (stats) {
            stats->limit_model = false;
            stats->points = 0; // not counted on the GPU
            stats->evaluations = 0;
        }
    }

    if (!m_out_texture) {
        // One output image for every dispatch, read back through a framebuffer.
        g.ActiveTexture(GL_TEXTURE1); // unit 0 holds the table
        g.GenTextures(1, &m_out_texture);
        g.BindTexture(GL_TEXTURE_2D, m_out_texture);
        g.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, kChunk, kChunk, 0, GL_RGBA, GL_FLOAT, nullptr);
        texel_fetch_only(g, GL_TEXTURE_2D);
        g.GenFramebuffers(1, &m_out_fbo);
        g.BindFramebuffer(GL_FRAMEBUFFER, m_out_fbo);
        g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, m_out_texture,
                               0);
        if (g.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
            if (mix_mask) g.DeleteTextures(1, &mix_mask);
            return make_error(ErrorCode::internal, m_name + ": float framebuffer incomplete");
        }
    }
    g.BindImageTexture(0, m_out_texture, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
    g.BindFramebuffer(GL_FRAMEBUFFER, m_out_fbo);
    const int cw = std::min(q.width, kChunk), ch = std::min(q.height, kChunk);
    core::Image out = take_image(q.width, q.height, nc); // every pixel is written
    std::vector<float> rgba(static_cast<std::size_t>(cw) * ch * 4);
    g.PixelStorei(GL_PACK_ALIGNMENT, 4);
    if (!m_timer) g.GenQueries(1, &m_timer);
    double gpu_ms = 0;
    bool skipped = false;
    for (int y0 = 0; y0 < q.height && !skipped; y0 += ch)
        for (int x0 = 0; x0 < q.width && !skipped; x0 += cw) {
            if (stopped(q.cancel)) {
                skipped = true;
                break;
            }
            const int w = std::min(cw, q.width - x0), h = std::min(ch, q.height - y0);
            g.Uniform2i(uniform("u_offset"), x0, y0);
            g.Uniform2i(uniform("u_size"), w, h);
            g.BeginQuery(GL_TIME_ELAPSED, m_timer);
            g.DispatchCompute(static_cast<GLuint>((w + 15) / 16),
                              static_cast<GLuint>((h + 15) / 16), 1);
            g.EndQuery(GL_TIME_ELAPSED);
            g.MemoryBarrier(GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
            g.ReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, rgba.data());
            GLuint64 ns = 0;
            g.GetQueryObjectui64v(m_timer, GL_QUERY_RESULT, &ns);
            gpu_ms += static_cast<double>(ns) * 1e-6;
            for (int c = 0; c < nc; ++c)
                for (int y = 0; y < h; ++y) {
                    const float* src = &rgba[static_cast<std::size_t>(y) * w * 4 + c];
                    float* dst = &out.at(c, x0, y0 + y);
                    for (int x = 0; x < w; ++x) dst[x] = src[static_cast<std::size_t>(x) * 4];
                }
        }
    if (stats) stats->gpu_ms = gpu_ms;
    const GLenum err = g.GetError();
    if (mix_mask) g.DeleteTextures(1, &mix_mask);
    if (err != GL_NO_ERROR)
        return make_error(ErrorCode::internal,
                          m_name + ": GL error " + std::to_string(static_cast<int>(err)));
    if (skipped) return abandoned(q.cancel, "the render");
    return out;
}

void GlBackend::upload_points(int k, const void* data, std::size_t bytes) {
    const gl::GlApi& g = *m_gl;
    if (!m_point_buffers[0]) g.GenBuffers(3, m_point_buffers);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, m_point_buffers[k]);
    if (bytes > m_point_capacity[k]) {
        m_point_capacity[k] = std::max(bytes, 2 * m_point_capacity[k]);
        g.BufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(m_point_capacity[k]),
                     nullptr, GL_DYNAMIC_DRAW);
    }
    g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(bytes), data);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, static_cast<GLuint>(1 + k), m_point_buffers[k]);
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
            link(g, {{GL_COMPUTE_SHADER, std::string("#version 450 core\n") + glsl::kNoiseLib +
                                             glsl::kSurfaceLib + glsl::kSurfaceNoiseComp}});
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
    g.BindTexture(GL_TEXTURE_2D, table_texture(table));
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
        auto prog = link(g, {{GL_VERTEX_SHADER, head + glsl::kMeshPreviewVert},
                             {GL_FRAGMENT_SHADER, head + glsl::kNoiseLib + glsl::kSurfaceLib +
                                                      glsl::kMeshPreviewFrag}});
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
    const double l = std::sqrt(0.4 * 0.4 + 0.8 * 0.8 + 0.6 * 0.6);
    g.Uniform3f(loc("u_light"), static_cast<float>(0.4 / l), static_cast<float>(0.8 / l),
                static_cast<float>(0.6 / l));
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
        auto prog = link(g, {{GL_COMPUTE_SHADER, std::string("#version 450 core\n") +
                                                     glsl::kNoiseLib + glsl::kSpecProbeComp}});
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
