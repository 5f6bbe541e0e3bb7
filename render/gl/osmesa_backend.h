#pragma once
// OpenGL 4.5 core in software through OSMesa (llvmpipe): the path that proves the GLSL on machines
// without a GPU. libOSMesa.so.8 is opened at run time.
#include "render/gl/gl_backend.h"

namespace textond::render {

Result<std::shared_ptr<GlBackend>>
make_osmesa_backend(const GlslSources& sources = GlslSources::embedded());

// A bare OpenGL 4.5 core context of its own (the engine kit's shader test draws with it).
Result<std::unique_ptr<GlContext>> make_osmesa_context();

} // namespace textond::render
