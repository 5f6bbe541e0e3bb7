#pragma once
// Picks a backend by name and says why: `auto` takes a real GPU through EGL when there is one,
// else the CPU path (on the same cores it is far faster than OSMesa's llvmpipe).
#include "core/result.h"
#include "render/backend.h"

#include <memory>
#include <string>
#include <string_view>

namespace textond::render {

enum class BackendKind { automatic, cpu, osmesa, egl };

Result<BackendKind> parse_backend_kind(std::string_view name); // auto | cpu | osmesa | egl
const char* to_string(BackendKind kind);

struct BackendOptions {
    int threads = 0; // CPU backend; 0 = all cores
    // EGL normally refuses software renderers (llvmpipe) so they are never mistaken for a GPU;
    // tests set this to run the EGL code path on machines without one.
    bool allow_software_egl = false;
};

struct BackendChoice {
    std::shared_ptr<Backend> backend;
    std::string reason; // what was tried and why this one was taken
};

Result<BackendChoice> make_backend(BackendKind kind, const BackendOptions& options = {});

} // namespace textond::render
