// The engine kit's two fragment entry points run, not only compile: the GLSL one (noise_lib +
// texton_eval + texton_noise.frag) and the HLSL translation (render/hlsl/texton_noise.hlsl: glslang
// makes SPIR-V with HLSL's cbuffer offsets, SPIRV-Cross turns it back into GLSL 4.50). Each is
// drawn under OSMesa as the kit's README tells an engine to (one full-screen triangle, the
// uniforms from the window, the table as an RGB32F texture) and compared with the CPU backend.
// The server's own GLSL is the compute entry (gl_backend_test); without this test, either kit
// shader could drift from it unnoticed.
#include "render/cpu_backend.h"
#include "render/embedded_sources.h"
#include "render/gl/gl_api.h"
#include "render/gl/noise_window.h"
#include "render/gl/osmesa_backend.h"
#include "render/normal_map.h"
#include "tests/render/render_fixtures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <type_traits>

#include <unistd.h>

namespace textond::test {
namespace {

namespace fs = std::filesystem;
using render::gl::NoiseWindow;

bool have(const char* tool) {
    return std::system((std::string("command -v ") + tool + " >/dev/null 2>&1").c_str()) == 0;
}

// What a draw sets: each uniform by its name in texton_eval.glsl, as 32-bit words.
struct Uniform {
    enum Kind { ints, uints, floats, rows3 } kind; // rows3: a 3x3 matrix, row after row
    std::string name;
    std::vector<std::uint32_t> words;
};

// The uniforms of `w` (texton_noise.comp's load_tile reads the same record slots).
std::vector<Uniform> uniforms_of(const NoiseWindow& w) {
    const auto& r = w.record;
    auto at = [&](int slot, int k, int n) {
        return std::vector<std::uint32_t>(r.begin() + 4 * slot + k, r.begin() + 4 * slot + k + n);
    };
    std::vector<Uniform> u = {
        {Uniform::ints, "u_mode", at(0, 0, 1)},
        {Uniform::ints, "u_level", at(0, 1, 1)},
        {Uniform::ints, "u_st", at(0, 2, 1)},
        {Uniform::ints, "u_sub_log2", at(0, 3, 1)},
        {Uniform::ints, "u_L", at(1, 0, 1)},
        {Uniform::ints, "u_r", at(1, 1, 1)},
        {Uniform::ints, "u_order", at(1, 2, 1)},
        {Uniform::ints, "u_a", at(1, 3, 1)},
        {Uniform::uints, "u_seed", at(2, 0, 2)},
        {Uniform::uints, "u_base_cx", at(2, 2, 2)},
        {Uniform::uints, "u_base_cy", at(3, 0, 2)},
        {Uniform::uints, "u_q0x", at(3, 2, 2)},
        {Uniform::uints, "u_q0y", at(4, 0, 2)},
        {Uniform::ints, "u_period", at(5, 0, 2)},
        {Uniform::ints, "u_base_mod", at(5, 2, 2)},
        {Uniform::ints, "u_origin", at(6, 0, 2)},
        {Uniform::ints, "u_offset", {0, 0}},
        {Uniform::ints, "u_channels", at(7, 3, 1)},
        {Uniform::floats, "u_mean", at(10, 0, 3)},
        {Uniform::floats, "u_scale", at(10, 3, 1)},
        {Uniform::uints, "u_thresholds", w.thresholds},
        {Uniform::ints, "u_nthresholds", {static_cast<std::uint32_t>(w.thresholds.size())}},
        {Uniform::floats, "u_kappa", at(11, 0, 25)},
        {Uniform::rows3, "u_A", {r[72], r[73], r[74], r[76], r[77], r[78], r[80], r[81], r[82]}}};
    return u;
}

// A GL context of the test's own, with the few functions GlApi leaves out (uniform blocks).
struct Gl {
    std::unique_ptr<render::GlContext> ctx;
    render::gl::GlApi f;
    PFNGLGETUNIFORMINDICESPROC GetUniformIndices = nullptr;
    PFNGLGETACTIVEUNIFORMSIVPROC GetActiveUniformsiv = nullptr;
    PFNGLGETUNIFORMBLOCKINDEXPROC GetUniformBlockIndex = nullptr;
    PFNGLUNIFORMBLOCKBINDINGPROC UniformBlockBinding = nullptr;
    PFNGLUNIFORM2UIVPROC Uniform2uiv = nullptr;
    PFNGLUNIFORM1IVPROC Uniform1iv = nullptr;
    PFNGLUNIFORM2IVPROC Uniform2iv = nullptr;
    PFNGLUNIFORM3FVPROC Uniform3fv = nullptr;
    PFNGLUNIFORM4FVPROC Uniform4fv = nullptr;
    PFNGLDRAWBUFFERSPROC DrawBuffers = nullptr;
    PFNGLREADBUFFERPROC ReadBuffer = nullptr;

    static std::unique_ptr<Gl> open() {
        auto c = render::make_osmesa_context();
        if (!c || !c.value()->make_current()) return nullptr;
        auto gl = std::make_unique<Gl>();
        gl->ctx = std::move(c.value());
        auto* ctx = gl->ctx.get();
        const std::string missing =
            gl->f.load([](const char* n,
                          void* u) { return static_cast<render::GlContext*>(u)->proc_address(n); },
                       ctx);
        if (!missing.empty()) return nullptr;
        auto get = [&](auto& fn, const char* name) {
            fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(ctx->proc_address(name));
            return fn != nullptr;
        };
        if (!get(gl->GetUniformIndices, "glGetUniformIndices") ||
            !get(gl->GetActiveUniformsiv, "glGetActiveUniformsiv") ||
            !get(gl->GetUniformBlockIndex, "glGetUniformBlockIndex") ||
            !get(gl->UniformBlockBinding, "glUniformBlockBinding") ||
            !get(gl->Uniform2uiv, "glUniform2uiv") || !get(gl->Uniform1iv, "glUniform1iv") ||
            !get(gl->Uniform2iv, "glUniform2iv") || !get(gl->Uniform3fv, "glUniform3fv") ||
            !get(gl->Uniform4fv, "glUniform4fv") || !get(gl->DrawBuffers, "glDrawBuffers") ||
            !get(gl->ReadBuffer, "glReadBuffer"))
            return nullptr;
        return gl;
    }
};

std::string shader_log(Gl& gl, GLuint sh) {
    GLint ok = 0;
    gl.f.GetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (ok) return "";
    char log[4096] = {0};
    gl.f.GetShaderInfoLog(sh, sizeof log, nullptr, log);
    return log[0] ? log : "compile failed";
}

// Links the full-screen vertex shader with `frag`; 0 and `error` set on failure.
GLuint program(Gl& gl, const std::string& frag, std::string& error) {
    const std::string vert = std::string("#version 450 core\n") + render::embedded::kFullscreenVert;
    GLuint p = gl.f.CreateProgram();
    for (auto [type, src] : {std::pair{GL_VERTEX_SHADER, vert}, {GL_FRAGMENT_SHADER, frag}}) {
        GLuint sh = gl.f.CreateShader(type);
        const char* s = src.c_str();
        gl.f.ShaderSource(sh, 1, &s, nullptr);
        gl.f.CompileShader(sh);
        error = shader_log(gl, sh);
        gl.f.AttachShader(p, sh);
        gl.f.DeleteShader(sh);
        if (!error.empty()) return 0;
    }
    gl.f.LinkProgram(p);
    GLint ok = 0;
    gl.f.GetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[4096] = {0};
        gl.f.GetProgramInfoLog(p, sizeof log, nullptr, log);
        error = std::string("link: ") + log;
        return 0;
    }
    return p;
}

// The GLSL entry: plain uniforms, as the kit's README sets them. `all_used`: every uniform must
// be active (the set entry leaves the limit model's out).
void set_plain(Gl& gl, GLuint p, const std::vector<Uniform>& us, bool all_used = true) {
    for (const auto& u : us) {
        const bool array = u.name == "u_thresholds" || u.name == "u_kappa";
        const GLint loc = gl.f.GetUniformLocation(p, (u.name + (array ? "[0]" : "")).c_str());
        if (loc < 0 && !all_used) continue;
        ASSERT_GE(loc, 0) << u.name;
        const auto n = static_cast<GLsizei>(u.words.size());
        const void* d = u.words.data();
        if (u.kind == Uniform::rows3)
            gl.f.UniformMatrix3fv(loc, 1, GL_TRUE, static_cast<const float*>(d));
        else if (u.kind == Uniform::uints && array)
            gl.f.Uniform1uiv(loc, n, static_cast<const GLuint*>(d));
        else if (u.kind == Uniform::uints)
            gl.Uniform2uiv(loc, 1, static_cast<const GLuint*>(d));
        else if (u.kind == Uniform::ints)
            (n == 1 ? gl.Uniform1iv : gl.Uniform2iv)(loc, 1, static_cast<const GLint*>(d));
        else if (array || n == 1)
            gl.f.Uniform1fv(loc, n, static_cast<const float*>(d));
        else if (n == 4)
            gl.Uniform4fv(loc, 1, static_cast<const float*>(d));
        else
            gl.Uniform3fv(loc, 1, static_cast<const float*>(d));
    }
    gl.f.Uniform1i(gl.f.GetUniformLocation(p, "u_table"), 0);
    gl.f.Uniform1i(gl.f.GetUniformLocation(p, "u_level_tables"), 2);
    gl.f.Uniform1i(gl.f.GetUniformLocation(p, "u_mask"), 3);
    gl.f.Uniform1i(gl.f.GetUniformLocation(p, "u_mix"), 0);
}

// The HLSL entry: its cbuffer as a uniform buffer, every member where the program says it is
// (the HLSL packs the arrays four to a register, so thresholds and kappas are contiguous words).
GLuint set_cbuffer(Gl& gl, GLuint p, const std::vector<Uniform>& us) {
    std::vector<std::uint32_t> block(2048, 0);
    for (const auto& u : us) {
        const std::string member =
            "TextonNoise." + (u.name == "u_thresholds" ? std::string("u_thresholds4[0]")
                              : u.name == "u_kappa"    ? std::string("u_kappa4[0]")
                                                       : u.name);
        const char* name = member.c_str();
        GLuint index = GL_INVALID_INDEX;
        gl.GetUniformIndices(p, 1, &name, &index);
        EXPECT_NE(index, GL_INVALID_INDEX) << member;
        if (index == GL_INVALID_INDEX) continue;
        GLint offset = 0, stride = 0;
        gl.GetActiveUniformsiv(p, 1, &index, GL_UNIFORM_OFFSET, &offset);
        gl.GetActiveUniformsiv(p, 1, &index, GL_UNIFORM_MATRIX_STRIDE, &stride);
        const std::size_t at = static_cast<std::size_t>(offset) / 4;
        if (u.kind == Uniform::rows3) // row_major: a register a row
            for (std::size_t row = 0; row < 3; ++row)
                std::copy_n(u.words.begin() + 3 * row, 3, block.begin() + at + row * stride / 4);
        else
            std::copy(u.words.begin(), u.words.end(), block.begin() + at);
    }
    GLuint buffer = 0;
    gl.f.GenBuffers(1, &buffer);
    gl.f.BindBuffer(GL_UNIFORM_BUFFER, buffer);
    gl.f.BufferData(GL_UNIFORM_BUFFER, block.size() * 4, block.data(), GL_STATIC_DRAW);
    gl.f.BindBufferBase(GL_UNIFORM_BUFFER, 0, buffer);
    gl.UniformBlockBinding(p, gl.GetUniformBlockIndex(p, "TextonNoise"), 0);
    return buffer;
}

enum class Entry { glsl, hlsl };

// The kit's marginals.glsl uniforms and this level's tables (R32F 256 x 3 on unit 4).
GLuint set_marginals(Gl& gl, GLuint p, const core::MarginalTables& t) {
    std::vector<float> rows(3 * core::MarginalTables::kEntries, 0.0f);
    float basis[9] = {0}, sigma[3] = {1, 1, 1}, mean[3] = {0, 0, 0};
    for (int i = 0; i < t.channels(); ++i) {
        std::copy_n(t.table(i), core::MarginalTables::kEntries,
                    rows.begin() + i * core::MarginalTables::kEntries);
        sigma[i] = static_cast<float>(t.sigma(i));
        mean[i] = static_cast<float>(t.mean()[std::size_t(i)]);
        for (int c = 0; c < t.channels(); ++c) basis[3 * i + c] = float(t.basis()(c, i)); // columns
    }
    GLuint tex = 0;
    gl.f.GenTextures(1, &tex);
    gl.f.ActiveTexture(GL_TEXTURE4);
    gl.f.BindTexture(GL_TEXTURE_2D, tex);
    gl.f.TexImage2D(GL_TEXTURE_2D, 0, GL_R32F, core::MarginalTables::kEntries, 3, 0, GL_RED,
                    GL_FLOAT, rows.data());
    gl.f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.f.ActiveTexture(GL_TEXTURE0);
    gl.f.Uniform1i(gl.f.GetUniformLocation(p, "u_marg_tables"), 4);
    gl.f.UniformMatrix3fv(gl.f.GetUniformLocation(p, "u_marg_basis"), 1, GL_FALSE, basis);
    gl.Uniform3fv(gl.f.GetUniformLocation(p, "u_marg_sigma"), 1, sigma);
    gl.Uniform3fv(gl.f.GetUniformLocation(p, "u_marg_mean"), 1, mean);
    gl.f.Uniform1i(gl.f.GetUniformLocation(p, "u_marg_channels"), t.channels());
    return tex;
}

// Draws window `q` of `tex` with `frag` (RGBA float, row y = pixel y); fails the test on a GL
// error.
std::vector<float> draw(Gl& gl, const std::string& frag, Entry entry,
                        const render::PreparedTexton& tex, const render::NoiseRequest& q,
                        const core::MarginalTables* marginals = nullptr) {
    const NoiseWindow w = render::gl::make_noise_window(tex, nullptr, q);
    auto& f = gl.f;
    EXPECT_TRUE(gl.ctx->make_current());
    std::string error;
    const GLuint p = program(gl, frag, error);
    EXPECT_NE(p, 0u) << error;
    if (p == 0) return {};
    f.UseProgram(p);
    const auto us = uniforms_of(w);
    GLuint ubo = 0, marg = 0;
    if (entry == Entry::glsl)
        set_plain(gl, p, us);
    else
        ubo = set_cbuffer(gl, p, us);
    if (marginals) marg = set_marginals(gl, p, *marginals);

    GLuint tex_ids[2] = {0, 0}, fbo = 0, vao = 0;
    f.GenTextures(2, tex_ids);
    f.ActiveTexture(GL_TEXTURE0);
    f.BindTexture(GL_TEXTURE_2D, tex_ids[0]);
    const int side = w.limit_model ? 1 : w.table->side();
    std::vector<float> texels(static_cast<std::size_t>(side) * side * 3, 0.0f);
    if (!w.limit_model) render::gl::interleave_table(*w.table, 3, texels.data());
    f.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, side, side, 0, GL_RGB, GL_FLOAT, texels.data());
    f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    f.ActiveTexture(GL_TEXTURE1); // the output: unit 0 keeps the table
    f.BindTexture(GL_TEXTURE_2D, tex_ids[1]);
    f.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, q.width, q.height, 0, GL_RGBA, GL_FLOAT, nullptr);
    f.GenFramebuffers(1, &fbo);
    f.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    f.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex_ids[1], 0);
    EXPECT_EQ(f.CheckFramebufferStatus(GL_FRAMEBUFFER), GLenum{GL_FRAMEBUFFER_COMPLETE});
    f.GenVertexArrays(1, &vao);
    f.BindVertexArray(vao);
    f.Viewport(0, 0, q.width, q.height);
    f.DrawArrays(GL_TRIANGLES, 0, 3);
    std::vector<float> out(static_cast<std::size_t>(q.width) * q.height * 4);
    f.PixelStorei(GL_PACK_ALIGNMENT, 1);
    f.ReadPixels(0, 0, q.width, q.height, GL_RGBA, GL_FLOAT, out.data());
    EXPECT_EQ(f.GetError(), GLenum{GL_NO_ERROR});
    f.DeleteVertexArrays(1, &vao);
    f.DeleteFramebuffers(1, &fbo);
    f.DeleteTextures(2, tex_ids);
    if (ubo) f.DeleteBuffers(1, &ubo);
    if (marg) f.DeleteTextures(1, &marg);
    f.DeleteProgram(p);
    gl.ctx->release();
    return out;
}

// An HLSL entry of the kit as GLSL 4.50 through SPIR-V: `files` are written side by side (for
// #include) and `main_file` compiled; "" and `error` set when a tool fails.
std::string hlsl_as_glsl(const std::vector<std::pair<std::string, const char*>>& files,
                         const std::string& main_file, std::string& error) {
    const fs::path dir = fs::temp_directory_path() / ("textond_hlsl_" + std::to_string(getpid()));
    fs::create_directories(dir);
    for (const auto& [name, text] : files) std::ofstream(dir / name) << text;
    const std::string d = "'" + dir.string() + "/";
    // --hlsl-offsets: the cbuffer's members where Direct3D puts them, not std140's.
    const std::string cmd = "glslangValidator -D -S frag -e main -V --hlsl-offsets " + d +
                            main_file + "' -o " + d + "t.spv' >" + d + "log' 2>&1 && " +
                            "spirv-cross " + d + "t.spv' --version 450 --no-es --output " + d +
                            "t.frag' >>" + d + "log' 2>&1";
    std::string out;
    if (std::system(cmd.c_str()) == 0) {
        std::stringstream s;
        s << std::ifstream(dir / "t.frag").rdbuf();
        out = s.str();
    } else {
        std::stringstream s;
        s << std::ifstream(dir / "log").rdbuf();
        error = s.str();
    }
    fs::remove_all(dir);
    return out;
}

std::string hlsl_as_glsl(std::string& error) {
    return hlsl_as_glsl({{"texton_noise.hlsl", render::embedded::kTextonNoiseHlsl}},
                        "texton_noise.hlsl", error);
}

struct Case {
    int level;
    std::int64_t x0, y0;
    double mni;
    std::uint64_t seed;
};

// Same bounds as the compute entry's (gl_backend_test, check_against_cpu): the same points in the
// same order with `precise` arithmetic leave ~1 ulp per operation, far below 1e-5 of the field's
// std; the limit model's log, cos and sin are not IEEE in GLSL, 1e-3.
void check_entry(Gl& gl, const std::string& frag, Entry entry, int order) {
    const auto tex = analysed_texton("etr_sand01.png", order == 3 ? 32 : 64, order);
    render::CpuBackend cpu;
    const std::int64_t far = std::int64_t{1} << 40;
    const std::uint64_t high = (std::uint64_t{1} << 32) + 77, top = ~std::uint64_t{0} - 5;
    std::vector<Case> cases = {{0, 0, 0, 30, 77},        {0, far, -far, 30, high},
                               {2, -50, 17, 30, 77},     {-1, 9, -4, 5, top},
                               {-3, far, far, 30, high}, {3, 100, 100, 200, high},
                               {0, 3, 3, 1, top},        {tex->limit_level(), 5, -5, 30, high}};
    for (const Case& c : cases) {
        render::NoiseRequest q;
        q.seed = c.seed;
        q.level = c.level;
        q.x0 = c.x0;
        q.y0 = c.y0;
        q.mni = c.mni;
        q.width = 37;
        q.height = 29;
        ASSERT_FALSE(tex->check(q).has_value());
        auto want = cpu.render(*tex, q);
        ASSERT_TRUE(want.ok());
        const auto got = draw(gl, frag, entry, *tex, q);
        ASSERT_EQ(got.size(), std::size_t(q.width) * q.height * 4);
        const bool limit = c.level >= tex->limit_level();
        for (int ch = 0; ch < 3; ++ch) {
            double worst = 0;
            for (int y = 0; y < q.height; ++y)
                for (int x = 0; x < q.width; ++x)
                    worst =
                        std::max(worst, std::fabs(double(want.value().at(ch, x, y)) -
                                                  got[(std::size_t(y) * q.width + x) * 4 + ch]));
            EXPECT_LE(worst, (limit ? 1e-3 : 1e-5) * field_std(*tex, ch))
                << (entry == Entry::glsl ? "GLSL" : "HLSL") << " order " << order << " level "
                << c.level << " x0 " << c.x0 << " seed " << c.seed << " channel " << ch;
        }
    }
}

std::string glsl_entry() {
    return std::string("#version 450 core\n") + render::embedded::kNoiseLib +
           render::embedded::kTextonEval + render::embedded::kTextonNoiseFrag;
}

TEST(KitShaders, GlslFragmentEntryAgreesWithCpu) {
    auto gl = Gl::open();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    for (int order : {1, 3}) check_entry(*gl, glsl_entry(), Entry::glsl, order);
}

// The kit's marginals.glsl, compiled into the fragment entry with TEXTOND_MARGINALS, against the
// CPU's marginals=exemplar: the same tables, float against double arithmetic around them (bound
// 1e-4 of the field's std, 1e-3 for the limit model as above).
TEST(KitShaders, MarginalsGlslAgreesWithCpu) {
    auto gl = Gl::open();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    const std::string frag = std::string("#version 450 core\n#define TEXTOND_MARGINALS\n") +
                             render::embedded::kNoiseLib + render::embedded::kTextonEval +
                             render::embedded::kMarginalsGlsl + render::embedded::kTextonNoiseFrag;
    render::CpuBackend cpu;
    for (const char* name : {"etr_pebbles04.png", "skimage_brick.png"}) {
        const auto tex = analysed_texton(name, 64);
        for (int level : {0, 2, -1, tex->limit_level() + 1}) {
            render::NoiseRequest q;
            q.seed = (std::uint64_t{1} << 32) + 9;
            q.level = level;
            q.x0 = -40;
            q.width = 37;
            q.height = 29;
            q.marginals = render::Marginals::exemplar;
            auto want = cpu.render(*tex, q);
            ASSERT_TRUE(want.ok());
            const auto got = draw(*gl, frag, Entry::glsl, *tex, q, tex->marginals(level).get());
            ASSERT_EQ(got.size(), std::size_t(q.width) * q.height * 4);
            q.marginals = render::Marginals::gaussian;
            auto gauss = cpu.render(*tex, q);
            const double bound = (level >= tex->limit_level() ? 1e-3 : 1e-4) * field_std(*tex, 0);
            double worst = 0, moved = 0;
            for (int ch = 0; ch < tex->channels(); ++ch)
                for (int y = 0; y < q.height; ++y)
                    for (int x = 0; x < q.width; ++x) {
                        const float g = got[(std::size_t(y) * q.width + x) * 4 + ch];
                        worst = std::max(worst, std::fabs(double(want.value().at(ch, x, y)) - g));
                        moved = std::max(moved, std::fabs(double(gauss.value().at(ch, x, y)) - g));
                    }
            EXPECT_LE(worst, bound) << name << " level " << level;
            // The map moves pixels well past the bound: a shader without it would fail above.
            EXPECT_GT(moved, 2 * bound) << name << " level " << level;
        }
    }
}

TEST(KitShaders, HlslAgreesWithCpu) {
    if (!have("glslangValidator") || !have("spirv-cross"))
        GTEST_SKIP() << "glslangValidator or spirv-cross missing (docker/install-deps.sh "
                        "installs glslang-tools and spirv-cross)";
    auto gl = Gl::open();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    std::string error;
    const std::string frag = hlsl_as_glsl(error);
    ASSERT_FALSE(frag.empty()) << error;
    for (int order : {1, 3}) check_entry(*gl, frag, Entry::hlsl, order);
}

// ---- A material set: material_eval.glsl + material_noise.frag, and material_noise.hlsl ----

// What the set entry writes: three RGBA float images (row y = pixel y).
struct SetDraw {
    std::vector<float> maps0, maps1, normal;
};

// The set entry's own uniforms (after texton_eval's, which the window gives as for one texton).
std::vector<Uniform> set_uniforms(const render::PreparedTexton& set, int height, float strength) {
    float mean[8] = {0};
    for (int c = 0; c < set.channels(); ++c)
        mean[c] = static_cast<float>(set.texton().mean[static_cast<std::size_t>(c)]);
    auto words = [](const float* f, int n) {
        std::vector<std::uint32_t> w(static_cast<std::size_t>(n));
        std::memcpy(w.data(), f, w.size() * 4);
        return w;
    };
    return {{Uniform::ints, "u_set_channels", {static_cast<std::uint32_t>(set.channels())}},
            {Uniform::ints, "u_height", {static_cast<std::uint32_t>(height)}},
            {Uniform::floats, "u_set_mean0", words(mean, 4)},
            {Uniform::floats, "u_set_mean1", words(mean + 4, 4)},
            {Uniform::floats, "u_strength", words(&strength, 1)}};
}

GLuint float_texture(Gl& gl, GLenum unit, int w, int h, const float* rgba) {
    GLuint t = 0;
    gl.f.GenTextures(1, &t);
    gl.f.ActiveTexture(unit);
    gl.f.BindTexture(GL_TEXTURE_2D, t);
    gl.f.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, rgba);
    gl.f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
}

// Draws window `q` of the set as the kit's README says: the level table's channels 0..3 and
// 4..7 as two RGBA32F textures on units 1 and 2, the normal's height channel and strength.
SetDraw draw_set(Gl& gl, const std::string& frag, Entry entry, const render::PreparedTexton& set,
                 const render::NoiseRequest& q, int height, float strength) {
    const NoiseWindow w = render::gl::make_noise_window(set, nullptr, q);
    auto& f = gl.f;
    EXPECT_TRUE(gl.ctx->make_current());
    std::string error;
    const GLuint p = program(gl, frag, error);
    EXPECT_NE(p, 0u) << error;
    if (p == 0) return {};
    f.UseProgram(p);
    auto us = uniforms_of(w);
    const auto extra = set_uniforms(set, height, strength);
    us.insert(us.end(), extra.begin(), extra.end());
    GLuint ubo = 0;
    // The HLSL's textures come out of SPIRV-Cross as combined samplers with these names.
    std::string t0 = "u_set_table0", t1 = "u_set_table1";
    if (entry == Entry::glsl) {
        set_plain(gl, p, us, false);
    } else {
        ubo = set_cbuffer(gl, p, us);
        t0 = "SPIRV_Cross_Combined" + t0 + "SPIRV_Cross_DummySampler";
        t1 = "SPIRV_Cross_Combined" + t1 + "SPIRV_Cross_DummySampler";
    }
    const int side = w.table->side();
    std::vector<float> all(std::size_t(side) * side * 8, 0.0f), part[2];
    render::gl::interleave_table(*w.table, 8, all.data());
    for (int k = 0; k < 2; ++k) {
        part[k].resize(std::size_t(side) * side * 4);
        for (std::size_t i = 0; i < std::size_t(side) * side; ++i)
            std::copy_n(all.begin() + 8 * i + 4 * k, 4, part[k].begin() + 4 * i);
    }
    GLuint tables[2] = {float_texture(gl, GL_TEXTURE1, side, side, part[0].data()),
                        float_texture(gl, GL_TEXTURE2, side, side, part[1].data())};
    f.Uniform1i(f.GetUniformLocation(p, t0.c_str()), 1);
    f.Uniform1i(f.GetUniformLocation(p, t1.c_str()), 2);
    GLuint outs[3], fbo = 0, vao = 0;
    f.GenFramebuffers(1, &fbo);
    f.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    const GLenum attachments[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                   GL_COLOR_ATTACHMENT2};
    for (int k = 0; k < 3; ++k) {
        outs[k] = float_texture(gl, GL_TEXTURE5, q.width, q.height, nullptr);
        f.FramebufferTexture2D(GL_FRAMEBUFFER, attachments[k], GL_TEXTURE_2D, outs[k], 0);
    }
    gl.DrawBuffers(3, attachments);
    EXPECT_EQ(f.CheckFramebufferStatus(GL_FRAMEBUFFER), GLenum{GL_FRAMEBUFFER_COMPLETE});
    f.GenVertexArrays(1, &vao);
    f.BindVertexArray(vao);
    f.Viewport(0, 0, q.width, q.height);
    f.DrawArrays(GL_TRIANGLES, 0, 3);
    SetDraw out;
    std::vector<float>* dest[3] = {&out.maps0, &out.maps1, &out.normal};
    f.PixelStorei(GL_PACK_ALIGNMENT, 1);
    for (int k = 0; k < 3; ++k) {
        dest[k]->resize(std::size_t(q.width) * q.height * 4);
        gl.ReadBuffer(attachments[k]);
        f.ReadPixels(0, 0, q.width, q.height, GL_RGBA, GL_FLOAT, dest[k]->data());
    }
    EXPECT_EQ(f.GetError(), GLenum{GL_NO_ERROR});
    f.DeleteVertexArrays(1, &vao);
    f.DeleteFramebuffers(1, &fbo);
    f.DeleteTextures(3, outs);
    f.DeleteTextures(2, tables);
    if (ubo) f.DeleteBuffers(1, &ubo);
    f.DeleteProgram(p);
    gl.ctx->release();
    return out;
}

// Every map of the set (its view's CPU tiles, what the server serves for map=NAME) and the normal
// map (render_normal_map) against one draw of the set entry. Maps: 1e-5 of the channel's std, as
// for one texton; normals: 1e-4, the bound for the normal map against the analytic
// gradient (float rounding of the gradient, amplified by the strength).
void check_set_entry(Gl& gl, const std::string& frag, Entry entry, int order) {
    const auto set = pebble_set(16, order, true);
    ASSERT_EQ(set->channels(), 5);
    const int height = 4;
    const float strength = 8.0f;
    render::CpuBackend cpu;
    const std::int64_t far = std::int64_t{1} << 40;
    const std::uint64_t high = (std::uint64_t{1} << 32) + 77, top = ~std::uint64_t{0} - 5;
    const std::vector<Case> cases = {
        {0, 0, 0, 30, 77}, {0, far, -far, 30, high}, {2, -50, 17, 30, 77}, {-1, 9, -4, 5, top}};
    const char* label = entry == Entry::glsl ? "GLSL" : "HLSL";
    for (const Case& c : cases) {
        render::NoiseRequest q;
        q.seed = c.seed;
        q.level = c.level;
        q.x0 = c.x0;
        q.y0 = c.y0;
        q.mni = c.mni;
        q.width = 37;
        q.height = 29;
        ASSERT_LT(c.level, set->limit_level());
        const SetDraw got = draw_set(gl, frag, entry, *set, q, height, strength);
        ASSERT_EQ(got.normal.size(), std::size_t(q.width) * q.height * 4);
        for (const auto& m : set->texton().maps) {
            auto view = set->map(m.name);
            ASSERT_TRUE(view.ok());
            auto want = cpu.render(*view.value(), q);
            ASSERT_TRUE(want.ok());
            for (int ch = 0; ch < m.channels; ++ch) {
                const int sc = m.first + ch; // the set's channel
                const auto& plane = sc < 4 ? got.maps0 : got.maps1;
                double worst = 0;
                for (int y = 0; y < q.height; ++y)
                    for (int x = 0; x < q.width; ++x)
                        worst = std::max(
                            worst, std::fabs(double(want.value().at(ch, x, y)) -
                                             plane[(std::size_t(y) * q.width + x) * 4 + sc % 4]));
                EXPECT_LE(worst, 1e-5 * field_std(*view.value(), ch))
                    << label << " order " << order << " level " << c.level << " map " << m.name
                    << " channel " << ch;
            }
        }
        auto h = set->map("height");
        ASSERT_TRUE(h.ok());
        auto normals = render::render_normal_map(cpu, *h.value(), q, strength);
        ASSERT_TRUE(normals.ok()) << normals.error().message;
        double worst = 0, tilt = 0;
        for (int ch = 0; ch < 3; ++ch)
            for (int y = 0; y < q.height; ++y)
                for (int x = 0; x < q.width; ++x) {
                    const double want = normals.value().at(ch, x, y);
                    worst = std::max(
                        worst,
                        std::fabs(want - got.normal[(std::size_t(y) * q.width + x) * 4 + ch]));
                    if (ch < 2) tilt = std::max(tilt, std::fabs(want - 0.5));
                }
        EXPECT_LE(worst, 1e-4) << label << " normals, order " << order << " level " << c.level;
        EXPECT_GT(tilt, 0.1) << "the window's normals must lean: a flat field checks nothing";
    }
}

std::string set_glsl_entry() {
    return std::string("#version 450 core\n") + render::embedded::kNoiseLib +
           render::embedded::kTextonEval + render::embedded::kMaterialEval +
           render::embedded::kMaterialNoiseFrag;
}

TEST(KitShaders, MaterialSetGlslAgreesWithCpu) {
    auto gl = Gl::open();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    for (int order : {1, 3}) check_set_entry(*gl, set_glsl_entry(), Entry::glsl, order);
}

TEST(KitShaders, MaterialSetHlslAgreesWithCpu) {
    if (!have("glslangValidator") || !have("spirv-cross"))
        GTEST_SKIP() << "glslangValidator or spirv-cross missing (docker/install-deps.sh "
                        "installs glslang-tools and spirv-cross)";
    auto gl = Gl::open();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    std::string error;
    const std::string frag =
        hlsl_as_glsl({{"texton_noise.hlsl", render::embedded::kTextonNoiseHlsl},
                      {"material_noise.hlsl", render::embedded::kMaterialNoiseHlsl}},
                     "material_noise.hlsl", error);
    ASSERT_FALSE(frag.empty()) << error;
    for (int order : {1, 3}) check_set_entry(*gl, frag, Entry::hlsl, order);
}

} // namespace
} // namespace textond::test
