#include "render/gl/egl_backend.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>

#include <cstring>
#include <string>
#include <vector>

namespace textond::render {

namespace {

// libEGL entry points, opened once per process.
struct EglLib {
    void* handle = nullptr;
    PFNEGLGETPROCADDRESSPROC GetProcAddress = nullptr;
    PFNEGLINITIALIZEPROC Initialize = nullptr;
    PFNEGLBINDAPIPROC BindAPI = nullptr;
    PFNEGLCHOOSECONFIGPROC ChooseConfig = nullptr;
    PFNEGLCREATECONTEXTPROC CreateContext = nullptr;
    PFNEGLDESTROYCONTEXTPROC DestroyContext = nullptr;
    PFNEGLMAKECURRENTPROC MakeCurrent = nullptr;
    PFNEGLQUERYSTRINGPROC QueryString = nullptr;
    PFNEGLGETERRORPROC GetError = nullptr;
    PFNEGLQUERYDEVICESEXTPROC QueryDevices = nullptr;
    PFNEGLGETPLATFORMDISPLAYEXTPROC GetPlatformDisplay = nullptr;
    std::string error;

    static const EglLib& get() {
        static const EglLib lib = [] {
            EglLib l;
            l.handle = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
            if (!l.handle) {
                l.error = "libEGL.so.1 not found (Debian package libegl1)";
                return l;
            }
            auto sym = [&](const char* n) { return dlsym(l.handle, n); };
            l.GetProcAddress = reinterpret_cast<PFNEGLGETPROCADDRESSPROC>(sym("eglGetProcAddress"));
            l.Initialize = reinterpret_cast<PFNEGLINITIALIZEPROC>(sym("eglInitialize"));
            l.BindAPI = reinterpret_cast<PFNEGLBINDAPIPROC>(sym("eglBindAPI"));
            l.ChooseConfig = reinterpret_cast<PFNEGLCHOOSECONFIGPROC>(sym("eglChooseConfig"));
            l.CreateContext = reinterpret_cast<PFNEGLCREATECONTEXTPROC>(sym("eglCreateContext"));
            l.DestroyContext = reinterpret_cast<PFNEGLDESTROYCONTEXTPROC>(sym("eglDestroyContext"));
            l.MakeCurrent = reinterpret_cast<PFNEGLMAKECURRENTPROC>(sym("eglMakeCurrent"));
            l.QueryString = reinterpret_cast<PFNEGLQUERYSTRINGPROC>(sym("eglQueryString"));
            l.GetError = reinterpret_cast<PFNEGLGETERRORPROC>(sym("eglGetError"));
            if (!l.GetProcAddress || !l.Initialize || !l.BindAPI || !l.ChooseConfig ||
                !l.CreateContext || !l.DestroyContext || !l.MakeCurrent || !l.QueryString ||
                !l.GetError) {
                l.error = "libEGL.so.1 lacks EGL 1.4 entry points";
                return l;
            }
            l.QueryDevices =
                reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(l.GetProcAddress("eglQueryDevicesEXT"));
            l.GetPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
                l.GetProcAddress("eglGetPlatformDisplayEXT"));
            if (!l.GetPlatformDisplay) l.error = "EGL has no eglGetPlatformDisplayEXT";
            return l;
        }();
        return lib;
    }
};

bool has_extension(const char* list, const char* name) {
    if (!list) return false;
    const std::size_t n = std::strlen(name);
    for (const char* p = std::strstr(list, name); p; p = std::strstr(p + 1, name))
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}

class EglContext final : public GlContext {
public:
    EglContext(EGLDisplay d, EGLContext c, std::string platform)
        : m_display(d), m_context(c), m_platform(std::move(platform)) {}
    ~EglContext() override { EglLib::get().DestroyContext(m_display, m_context); }
    bool make_current() override {
        return EglLib::get().MakeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, m_context) ==
               EGL_TRUE;
    }
    void release() override {
        EglLib::get().MakeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    void* proc_address(const char* name) override {
        return reinterpret_cast<void*>(EglLib::get().GetProcAddress(name));
    }
    std::string platform() const override { return m_platform; }

private:
    EGLDisplay m_display;
    EGLContext m_context;
    std::string m_platform;
};

// An OpenGL 4.5 core context without surfaces on `display`, or why not.
Result<std::unique_ptr<GlContext>> context_on(EGLDisplay display, const std::string& platform) {
    const EglLib& egl = EglLib::get();
    EGLint major = 0, minor = 0;
    if (display == EGL_NO_DISPLAY || !egl.Initialize(display, &major, &minor))
        return make_error(ErrorCode::unsupported, platform + ": eglInitialize failed");
    const char* ext = egl.QueryString(display, EGL_EXTENSIONS);
    if (!has_extension(ext, "EGL_KHR_surfaceless_context"))
        return make_error(ErrorCode::unsupported, platform + ": no EGL_KHR_surfaceless_context");
    if (!egl.BindAPI(EGL_OPENGL_API))
        return make_error(ErrorCode::unsupported, platform + ": no desktop OpenGL API");
    const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                     EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint n = 0;
    if (!egl.ChooseConfig(display, config_attribs, &config, 1, &n) || n < 1) {
        if (!has_extension(ext, "EGL_KHR_no_config_context"))
            return make_error(ErrorCode::unsupported, platform + ": no OpenGL config");
        config = nullptr; // EGL_NO_CONFIG_KHR
    }
    const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                  4,
                                  EGL_CONTEXT_MINOR_VERSION,
                                  5,
                                  EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                  EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                  EGL_NONE};
    EGLContext ctx = egl.CreateContext(display, config, EGL_NO_CONTEXT, ctx_attribs);
    if (ctx == EGL_NO_CONTEXT)
        return make_error(ErrorCode::unsupported, platform +
                                                      ": no OpenGL 4.5 core context (EGL error " +
                                                      std::to_string(egl.GetError()) + ")");
    return std::unique_ptr<GlContext>(new EglContext(display, ctx, platform));
}

} // namespace

Result<std::shared_ptr<GlBackend>> make_egl_backend(bool allow_software) {
    const EglLib& egl = EglLib::get();
    if (!egl.error.empty()) return make_error(ErrorCode::unsupported, "egl: " + egl.error);
    std::string tried;
    auto attempt = [&](EGLDisplay d, const std::string& platform) -> std::shared_ptr<GlBackend> {
        auto ctx = context_on(d, platform);
        if (!ctx) {
            tried += (tried.empty() ? "" : "; ") + ctx.error().message;
            return nullptr;
        }
        auto b = GlBackend::create("egl", std::move(ctx.value()), allow_software);
        if (!b) {
            tried += (tried.empty() ? "" : "; ") + platform + ": " + b.error().message;
            return nullptr;
        }
        return b.value();
    };
    if (egl.QueryDevices) {
        EGLDeviceEXT devices[16];
        EGLint count = 0;
        if (egl.QueryDevices(16, devices, &count)) {
            for (EGLint i = 0; i < count; ++i) {
                EGLDisplay d = egl.GetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
                if (auto b = attempt(d, "EGL device " + std::to_string(i))) return b;
            }
            if (count == 0) tried = "no EGL devices";
        }
    } else {
        tried = "no EGL_EXT_device_enumeration";
    }
    EGLDisplay d =
        egl.GetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (auto b = attempt(d, "EGL surfaceless")) return b;
    return make_error(ErrorCode::unsupported, "egl: no GPU renderer (" + tried + ")");
}

} // namespace textond::render
