#pragma once
// The window on the noise's plane, as render and mix read it from their flags.
#include "core/result.h"
#include "render/noise_request.h"
#include "server/cli/args.h"

namespace textond::cli {

// --x, --y (signed 64-bit), --w, --h (1..kMaxWindowSide, `width` x `height` by default), --lod
// (-4..24) and --mni (1..200); the seed and the period are the command's.
Result<render::NoiseRequest> window_from(const Args& a, int width, int height);

} // namespace textond::cli
