#pragma once
// A texture mix on disk: `<id>.exr` holds the R level textons stacked vertically (r x rR, float32,
// lossless) with the metadata JSON in the header attribute "textond:mix"; a mask field's image is
// `<id>.mask.exr`, written first and named by its sha256 in the metadata, so the main file's
// presence means the whole mix is there.
#include "api/mix_meta.h"
#include "core/result.h"
#include "core/texton.h"
#include "core/texture_mix.h"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace textond::io {

inline constexpr const char* kMixAttribute = "textond:mix";
// The sha256 of the levels' floats and of the means and RME the metadata gives them: a file
// changed on disk is refused, never lent to a variant under another id.
inline constexpr const char* kMixLevelsAttribute = "textond:mix_levels_sha256";

// MixMeta's field is an nlohmann::json, whose noexcept move calls its invariant check, which
// clang-tidy takes for a throw.
// NOLINTNEXTLINE(bugprone-exception-escape)
struct MixRecord {
    api::MixMeta meta;
    std::vector<core::Texton> levels;
    core::MixField field;
    // Read from a file that carries kMixLevelsAttribute and matches it (files of older builds do
    // not carry it): only such levels are lent to a field variant.
    bool levels_verified = false;
};

// Content address of a mix: its version, both texton ids, the level count and the canonical
// field (a mask by the sha256 of its float pixels); and `fft_grid`, the grid, where core::mix_grid
// cut the exemplars' common size (to the 1024 window or a fast FFT size): builds before that cut
// analysed the common size itself, a different computation, so it must be a different id.
std::string mix_id(const std::string& u, const std::string& v, int levels,
                   const core::MixField& field,
                   const std::optional<std::array<int, 2>>& fft_grid = std::nullopt);
// The field as JSON (meta["field"]) and back (the mask's pixels travel separately).
nlohmann::json field_json(const core::MixField& field);

Result<bool> write_mix_files(const std::string& dir, const MixRecord& record);
// `levels_only`: the metadata and levels, without the field (no mask decoded) and so without the
// check that the content hashes to the id; for a field variant that reuses them (mix_service.h).
Result<MixRecord> read_mix_files(const std::string& dir, const std::string& id,
                                 bool levels_only = false);

} // namespace textond::io
