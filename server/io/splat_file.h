#pragma once
// A splat map on disk: `<id>.json` holds its metadata (api::SplatMeta); image weights are
// `<id>.weights.exr` (float, one channel a layer), written first and named by the sha256 of
// their pixels in the metadata, so the JSON's presence means the whole splat is there. The layer
// textons are the store's, by id.
#include "api/splat_meta.h"
#include "core/result.h"
#include "core/splat_blend.h"

#include <string>
#include <vector>

namespace textond::io {

// NOLINTNEXTLINE(bugprone-exception-escape): SplatMeta holds an nlohmann::json (splat_meta.h).
struct SplatRecord {
    api::SplatMeta meta;
    core::SplatWeights weights;
    std::string height; // rules: the height texton's id
};

// Content address: the version, the layer ids in order and the canonical weights JSON.
std::string splat_id(const std::vector<std::string>& textons, const nlohmann::json& weights);

Result<bool> write_splat_files(const std::string& dir, const SplatRecord& record);
// not_found when there is none; io when its files are damaged or fail today's rules.
Result<SplatRecord> read_splat_files(const std::string& dir, const std::string& id);

} // namespace textond::io
