#pragma once
// Texton metadata: what `textond analyze` prints, what the texton file carries, and (later) what
// GET /v1/textons/{id} answers. JSON field names are part of the API; see api/TEXTON_FORMAT.md.
#include "core/texton_analysis.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <string>

namespace textond::api {

inline constexpr double kDefaultMni = 30.0;

struct TextonMeta {
    std::string id;      // sha256 of pixels + parameters + version (texton_id)
    std::string version; // core::kAnalysisVersion that produced it
    int exemplar_width = 0;
    int exemplar_height = 0;
    int channels = 0;
    std::array<double, 3> mean{};
    int size = 0;
    int order = 1;
    int iterations = 0;
    std::uint64_t seed = 0;
    bool periodic = true;
    double mni_default = kDefaultMni;
    double rme = 0;
    double rme_uncorrected = 0;
    core::AnalysisTimings timings;
    std::string coefficients_sha256; // of the float32 coefficients as stored, checked on load
    std::string created;             // RFC 3339 UTC, set when the service stores it; may be empty

    core::AnalysisParams params() const;
};

// The parameters that change the texton, in a canonical JSON form (keys sorted): part of the id.
nlohmann::json canonical_params(const core::AnalysisParams& p);

void to_json(nlohmann::json& j, const TextonMeta& m);
void from_json(const nlohmann::json& j, TextonMeta& m);

} // namespace textond::api
