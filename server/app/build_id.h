#pragma once
#include <string>

namespace textond::app {

// Identifies the build in ETags and /healthz: version, commit, noise and analysis versions.
const std::string& build_id();

} // namespace textond::app
