#pragma once
// The engine kit (GET /v1/textons/{id}/kit.tar): everything a game client needs to evaluate the
// server's texton noise on its own GPU, frame by frame, with the same bits as the tiles up to
// float rounding: the coefficients (EXR float32 and 16-bit PNG), the GLSL the server runs, its
// HLSL translation, NOISE_SPEC.md, a JSON of the parameters and a README with the shader in use.
#include "core/result.h"
#include "server/io/texton_file.h"

#include <string>

namespace textond::app {

// `texton_exr` is the stored texton file (float32 coefficients); `base_url` prefixes the tile
// URLs quoted in the README (may be empty).
Result<std::string> engine_kit_tar(const io::TextonRecord& record, const std::string& texton_exr,
                                   double mni, const std::string& base_url);

// The directory every kit entry lives in: "textond-kit-" and the id's first 12 characters.
std::string engine_kit_directory(const std::string& id);

} // namespace textond::app
