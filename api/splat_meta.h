#pragma once
// Splat-map metadata: what GET /v1/splats/{id} answers (with links added by the route) and what
// the splat file carries (server/io/splat_file.h). JSON field names are part of the API (the
// Splat schema of api/openapi.yaml).
#include "core/splat_blend.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace textond::api {

// weights is an nlohmann::json, whose noexcept move clang-tidy takes for a throw.
// NOLINTNEXTLINE(bugprone-exception-escape)
struct SplatMeta {
    std::string id;      // io::splat_id: version, layer ids and the canonical weights
    std::string version; // core::kSplatVersion
    std::vector<std::string> textons;
    int channels = 3;
    nlohmann::json weights; // splat_weights_json
    std::string created;    // RFC 3339 UTC; may be empty
};

void to_json(nlohmann::json& j, const SplatMeta& m);
void from_json(const nlohmann::json& j, SplatMeta& m);

// The weights as JSON: an image by its placement, size and the sha256 of its float pixels
// (`image_sha256`); rules with every band (null for no bound) and the height texton's id.
nlohmann::json splat_weights_json(const core::SplatWeights& w, const std::string& image_sha256,
                                  const std::string& height_id);
// And back, all but an image's pixels; throws nlohmann's exceptions on a malformed document.
core::SplatWeights splat_weights_from_json(const nlohmann::json& j, std::string& height_id);

} // namespace textond::api
