#include "render/backend_factory.h"

#include "render/cpu_backend.h"
#include "render/egl_backend.h"
#include "render/osmesa_backend.h"

namespace textond::render {

Result<BackendKind> parse_backend_kind(std::string_view name) {
    if (name == "auto") return BackendKind::automatic;
    if (name == "cpu") return BackendKind::cpu;
    if (name == "osmesa") return BackendKind::osmesa;
    if (name == "egl") return BackendKind::egl;
    return make_error(ErrorCode::invalid_argument,
                      "unknown backend '" + std::string(name) + "' (auto, cpu, osmesa or egl)");
}

const char* to_string(BackendKind kind) {
    switch (kind) {
    case BackendKind::automatic:
        return "auto";
    case BackendKind::cpu:
        return "cpu";
    case BackendKind::osmesa:
        return "osmesa";
    case BackendKind::egl:
        return "egl";
    }
    return "?";
}

Result<BackendChoice> make_backend(BackendKind kind, const BackendOptions& options) {
    auto cpu = [&](std::string reason) {
        auto b = std::make_shared<CpuBackend>(options.threads);
        return BackendChoice{b, reason + b->renderer()};
    };
    switch (kind) {
    case BackendKind::cpu:
        return cpu("asked for cpu: ");
    case BackendKind::osmesa: {
        auto b = make_osmesa_backend();
        if (!b) return b.error();
        return BackendChoice{b.value(), "asked for osmesa: " + b.value()->renderer()};
    }
    case BackendKind::egl: {
        auto b = make_egl_backend(options.allow_software_egl);
        if (!b) return b.error();
        return BackendChoice{b.value(), "asked for egl: " + b.value()->renderer()};
    }
    case BackendKind::automatic: {
        auto b = make_egl_backend(false);
        if (b) return BackendChoice{b.value(), "auto: GPU found, " + b.value()->renderer()};
        return cpu("auto: no GPU (" + b.error().message + "), so ");
    }
    }
    return make_error(ErrorCode::internal, "unknown backend kind");
}

} // namespace textond::render
