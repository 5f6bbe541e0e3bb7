#pragma once
// Texture-mix metadata: what GET /v1/mixes/{id} answers (with links added by the route) and what
// the mix file carries (server/io/mix_file.h). JSON field names are part of the API (the Mix
// schema of api/openapi.yaml).
#include "core/texton_analysis.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace textond::api {

// field is an nlohmann::json, whose noexcept move calls its invariant check, which clang-tidy
// takes for a throw.
// NOLINTNEXTLINE(bugprone-exception-escape)
struct MixMeta {
    std::string id;      // io::mix_id: version, both texton ids, level count, canonical field
    std::string version; // core::kMixVersion
    std::string u, v;    // the two textons' ids
    int levels = 0;
    // The analysis parameters, u's (a mix is analysed at one size, order, seed...).
    int size = 0, order = 1, channels = 0, iterations = 0;
    std::uint64_t seed = 0;
    bool periodic = true;
    std::array<int, 2> grid{};              // core::mix_grid: the common size, FFT-cut
    std::vector<std::vector<double>> means; // mean colour per level
    std::vector<double> rme;                // RME per level
    nlohmann::json field;                   // io::field_json
    std::optional<double> analysis_ms;      // unknown in files of older builds
    std::string created;                    // RFC 3339 UTC; may be empty

    core::AnalysisParams params() const;
};

void to_json(nlohmann::json& j, const MixMeta& m);
void from_json(const nlohmann::json& j, MixMeta& m);

} // namespace textond::api
