#pragma once
// A headless GPU through EGL: devices from EGL_EXT_device_enumeration on the device platform
// (NVIDIA's documented path), then Mesa's surfaceless platform. GL_RENDERER is checked so a
// software fallback (llvmpipe) is never mistaken for a GPU. libEGL.so.1 is opened at run time.
#include "render/gl/gl_backend.h"

namespace textond::render {

// The first hardware renderer found; with `allow_software`, a software one when no GPU exists
// (tests use this to run the EGL code path without a GPU).
Result<std::shared_ptr<GlBackend>> make_egl_backend(bool allow_software = false);

} // namespace textond::render
