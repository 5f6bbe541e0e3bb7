#pragma once
// The OpenGL evaluator shared by the OSMesa and EGL backends: the same GLSL (render/glsl/) on
// whatever context the platform code made. Owns its context; one render at a time (a mutex), made
// current on the calling thread for the call and released after, so any thread may call it.
#include "render/backend.h"
#include "render/surface_eval.h"

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace textond::render {

namespace gl {
struct GlApi;
}

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

    // Test hook: runs render/glsl/spec_probe.comp on `queries` (8 words each) with the given
    // Poisson thresholds; returns 64 words per query.
    Result<std::vector<std::uint32_t>> probe(const std::vector<std::uint32_t>& queries,
                                             const std::vector<std::uint32_t>& thresholds);

private:
    GlBackend(std::string name, std::unique_ptr<GlContext> context);
    Result<bool> init(bool allow_software, const GlslSources& sources);
    Result<core::Image> render_impl(const PreparedTexton& texton, const PreparedMix* mix,
                                    const NoiseRequest& request, RenderStats* stats);
    unsigned table_texture(const std::shared_ptr<const LevelTable>& table);
    int uniform(const char* name);

    std::string m_name;
    std::unique_ptr<GlContext> m_context;
    std::unique_ptr<gl::GlApi> m_gl;
    std::string m_renderer;
    std::string m_version;
    bool m_software = false;
    int m_subpixel_bits = 4;
    std::mutex m_mutex;
    unsigned m_program = 0, m_probe_program = 0, m_surface_program = 0, m_mesh_program = 0,
             m_vao = 0;
    // The output image of every noise dispatch (kChunk^2 RGBA32F, made once) and the
    // framebuffer it is read back through.
    unsigned m_out_texture = 0, m_out_fbo = 0;
    unsigned m_timer = 0; // the GL_TIME_ELAPSED query of every dispatch
    // The window's points and each cell's first point (texton_noise.comp, u_list = 1), grown as
    // needed and reused.
    unsigned m_point_buffers[3] = {0, 0, 0};
    std::size_t m_point_capacity[3] = {0, 0, 0};
    // Copies `bytes` into buffer k (0 the cell starts, 1 the points, 2 a mix's level tables) and
    // binds it to 1 + k.
    void upload_points(int k, const void* data, std::size_t bytes);

    // Uniforms shared by surface_lib.glsl's users (the compute and the mesh programs).
    void set_surface_uniforms(unsigned program, const PreparedTexton& texton, std::uint64_t seed,
                              double mni);
    std::map<std::string, int> m_uniforms;
    struct CachedTable {
        std::shared_ptr<const LevelTable> table; // keeps the key alive while cached
        unsigned texture = 0;
    };
    std::map<const LevelTable*, CachedTable> m_tables;        // textures (surface, mesh)
    std::map<const LevelTable*, CachedTable> m_table_buffers; // buffers (noise; `texture` = buffer)
    unsigned table_buffer(const std::shared_ptr<const LevelTable>& table);
};

} // namespace textond::render
