#include "render/gl/osmesa_backend.h"

#include <GL/osmesa.h>
#include <dlfcn.h>

#include <vector>

namespace textond::render {

namespace {

class OsmesaContext final : public GlContext {
public:
    using CreateFn = OSMesaContext (*)(const int*, OSMesaContext);
    using MakeCurrentFn = GLboolean (*)(OSMesaContext, void*, GLenum, GLsizei, GLsizei);
    using GetProcFn = OSMESAproc (*)(const char*);
    using DestroyFn = void (*)(OSMesaContext);

    static Result<std::unique_ptr<OsmesaContext>> open() {
        void* lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL);
        if (!lib) lib = dlopen("libOSMesa.so", RTLD_NOW | RTLD_LOCAL);
        if (!lib)
            return make_error(ErrorCode::unsupported,
                              "osmesa: libOSMesa.so.8 not found (Debian package libosmesa6)");
        // The library stays loaded for the life of the process: it is never dlclosed.
        std::unique_ptr<OsmesaContext> c(new OsmesaContext());
        c->m_create = reinterpret_cast<CreateFn>(dlsym(lib, "OSMesaCreateContextAttribs"));
        c->m_make_current = reinterpret_cast<MakeCurrentFn>(dlsym(lib, "OSMesaMakeCurrent"));
        c->m_get_proc = reinterpret_cast<GetProcFn>(dlsym(lib, "OSMesaGetProcAddress"));
        c->m_destroy = reinterpret_cast<DestroyFn>(dlsym(lib, "OSMesaDestroyContext"));
        if (!c->m_create || !c->m_make_current || !c->m_get_proc || !c->m_destroy)
            return make_error(ErrorCode::unsupported,
                              "osmesa: libOSMesa lacks the 4.x context API");
        const int attribs[] = {OSMESA_FORMAT,
                               OSMESA_RGBA,
                               OSMESA_DEPTH_BITS,
                               0,
                               OSMESA_STENCIL_BITS,
                               0,
                               OSMESA_ACCUM_BITS,
                               0,
                               OSMESA_PROFILE,
                               OSMESA_CORE_PROFILE,
                               OSMESA_CONTEXT_MAJOR_VERSION,
                               4,
                               OSMESA_CONTEXT_MINOR_VERSION,
                               5,
                               0};
        c->m_ctx = c->m_create(attribs, nullptr);
        if (!c->m_ctx)
            return make_error(ErrorCode::unsupported,
                              "osmesa: no OpenGL 4.5 core context (Mesa too old?)");
        return c;
    }

    ~OsmesaContext() override {
        if (m_ctx) m_destroy(m_ctx);
        // The library stays loaded: Mesa does not support being unloaded and reloaded.
    }

    bool make_current() override {
        return m_make_current(m_ctx, m_pixel.data(), GL_UNSIGNED_BYTE, 1, 1) == GL_TRUE;
    }
    void release() override { m_make_current(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0); }
    void* proc_address(const char* name) override {
        return reinterpret_cast<void*>(m_get_proc(name));
    }
    std::string platform() const override { return "OSMesa"; }

private:
    OsmesaContext() : m_pixel(4) {}
    std::vector<unsigned char> m_pixel; // OSMesa wants a colour buffer; we draw into an FBO
    OSMesaContext m_ctx = nullptr;
    CreateFn m_create = nullptr;
    MakeCurrentFn m_make_current = nullptr;
    GetProcFn m_get_proc = nullptr;
    DestroyFn m_destroy = nullptr;
};

} // namespace

Result<std::unique_ptr<GlContext>> make_osmesa_context() {
    auto ctx = OsmesaContext::open();
    if (!ctx) return ctx.error();
    return std::unique_ptr<GlContext>(std::move(ctx.value()));
}

Result<std::shared_ptr<GlBackend>> make_osmesa_backend(const GlslSources& sources) {
    auto ctx = OsmesaContext::open();
    if (!ctx) return ctx.error();
    return GlBackend::create("osmesa", std::move(ctx.value()), /*allow_software=*/true, sources);
}

} // namespace textond::render
