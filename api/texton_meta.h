#pragma once
// Texton metadata: what `textond analyze` prints, what the texton file carries, and (later) what
// GET /v1/textons/{id} answers. JSON field names are part of the API; see api/TEXTON_FORMAT.md.
#include "core/texton_analysis.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace textond::api {

// Now, as the metadata's `created` field writes it: 2026-11-26T04:20:00Z (UTC).
std::string rfc3339_now();

inline constexpr double kDefaultMni = 30.0;

// One map of a material set (core/material_set.h), as the metadata lists it.
struct MapMeta {
    std::string name;
    int first = 0;                            // its first channel in the texton
    int channels = 1;                         // 3 for albedo, else 1
    int bits = 8;                             // the uploaded file's bits per channel (8, 16 or 32)
    std::vector<std::array<double, 2>> range; // per channel: the exemplar's min and max
    double rme = 0;                           // of its channels alone
};

struct TextonMeta {
    std::string id;      // sha256 of pixels + parameters + version (texton_id)
    std::string version; // core::kAnalysisVersion that produced it
    int exemplar_width = 0;
    int exemplar_height = 0;
    int channels = 0;
    core::ChannelValues mean{};
    int size = 0;
    int order = 1;
    int iterations = 0;
    std::uint64_t seed = 0;
    bool periodic = true;
    double mni_default = kDefaultMni;
    double rme = 0;
    double rme_uncorrected = 0;
    std::string coefficients_sha256; // of the float32 coefficients as stored, checked on load
    // The exemplar's phase coherence (core/phase_coherence.h) and Leclaire-Moisan sharpness index;
    // absent from texton files written before they were computed.
    std::optional<double> phase_coherence, sharpness_index;
    // The micro/macro verdict's score (core/shape_verdict.h, log-odds of macro); absent from
    // texton files written before it was computed, whose kind comes from phase_coherence.
    std::optional<double> shape_score;
    // Whether the texton keeps the exemplar's marginals (marginals=exemplar renders); false for
    // mixes and files written before they were kept.
    bool exemplar_marginals = false;
    // A material set's maps, side by side in the channels; empty for one exemplar.
    std::vector<MapMeta> maps;
    // Provenance: how this copy came to be, not what it is. Never in the texton file, which is
    // content-addressed and must be the same bytes whoever analysed it and when.
    std::optional<core::AnalysisTimings> timings; // unknown for a texton read from a file alone
    std::string created; // RFC 3339 UTC, set when the service stores it; may be empty

    core::AnalysisParams params() const;
    // "micro", "borderline" or "macro": core::shape_kind of shape_score, or for older files
    // core::texture_kind of phase_coherence; "" when unknown.
    std::string kind() const;
    // The kind in plain words with what the noise loses, and whether the RME says the texton
    // misses its model (core::kMissedModelRme): "keeps its look" only for a micro-texture whose
    // texton is close to its model.
    std::string verdict() const;
};

// The parameters that change the texton, in a canonical JSON form (keys sorted): part of the id.
nlohmann::json canonical_params(const core::AnalysisParams& p);

// Everything but the provenance: what the texton file carries (same analysis, same bytes).
nlohmann::json file_meta_json(const TextonMeta& m);
// `created` and `timings_ms`, each only when known.
nlohmann::json provenance_json(const TextonMeta& m);
// Takes `created` and `timings_ms` from j where present (the other fields are left alone).
void read_provenance(const nlohmann::json& j, TextonMeta& m);

// Both together: the metadata answer, `textond analyze`'s summary, the shared store's index.
void to_json(nlohmann::json& j, const TextonMeta& m);
// Provenance is optional (absent from files; files written before it moved out carry it).
void from_json(const nlohmann::json& j, TextonMeta& m);

} // namespace textond::api
