#pragma once
// The GLSL files of render/glsl/, embedded at build time (see render/CMakeLists.txt).
namespace textond::render::glsl {
extern const char* const kNoiseLib;
extern const char* const kFullscreenVert;
extern const char* const kTextonNoiseFrag;
extern const char* const kSpecProbeComp;
} // namespace textond::render::glsl
