#include "server/app/build_id.h"

#include "core/texton_analysis.h"
#include "render/noise_request.h"

#include <OpenImageIO/oiioversion.h>

#ifndef TEXTOND_GIT_COMMIT
#define TEXTOND_GIT_COMMIT "unknown"
#endif
#ifndef TEXTOND_VERSION
#define TEXTOND_VERSION "0.0.0"
#endif

namespace textond::app {

const std::string& build_id() {
    // The PNG/EXR encoder is part of what produced a tile's bytes, so its version is too.
    static const std::string id = std::string("textond/") + TEXTOND_VERSION + "+" +
                                  TEXTOND_GIT_COMMIT + " " + render::kNoiseVersion + " " +
                                  core::kAnalysisVersion + " oiio/" OIIO_VERSION_STRING;
    return id;
}

} // namespace textond::app
