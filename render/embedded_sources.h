#pragma once
// The shaders of render/glsl/ and render/hlsl/ and render/NOISE_SPEC.md, embedded at build time
// (see render/CMakeLists.txt).
namespace textond::render::embedded {
extern const char* const kNoiseLib;
extern const char* const kFullscreenVert;
extern const char* const kTextonNoiseFrag;
extern const char* const kTextonEval;
extern const char* const kTextonNoiseComp;
extern const char* const kSpecProbeComp;
extern const char* const kTextonNoiseHlsl;
extern const char* const kMarginalsGlsl;
extern const char* const kNoiseSpec;
extern const char* const kSurfaceNoiseComp;
extern const char* const kSurfaceLib;
extern const char* const kMeshPreviewVert;
extern const char* const kMeshPreviewFrag;
extern const char* const kMaterialEval;      // a material set's maps and height gradient (kit)
extern const char* const kMaterialNoiseFrag; // its fragment entry (three attachments)
extern const char* const kMaterialNoiseHlsl; // its HLSL, which includes kTextonNoiseHlsl
} // namespace textond::render::embedded
