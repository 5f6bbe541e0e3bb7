#pragma once
// A splat map on disk: `<id>.json` holds its metadata (api::SplatMeta); image weights are the
// weight images as they were uploaded, at their own depth (`<id>.weights.upload`, and
// `<id>.weights2.upload` for layers 5 to 8), decoded again at load by the same code as at
// creation, so their planes are the same floats, named by the sha256 of those pixels in the
// metadata. Splats stored before (`<id>.weights.exr`, float, one channel a layer) are still read;
// a 16.8 MB upload of 8-bit weights was a 51.9 MB EXR. Written first, the JSON last, so the JSON's
// presence means the whole splat is there. The layer textons are the store's, by id.
#include "api/splat_meta.h"
#include "core/result.h"
#include "core/splat_blend.h"
#include "server/io/image_io.h"

#include <string>
#include <string_view>
#include <vector>

namespace textond::io {

// NOLINTNEXTLINE(bugprone-exception-escape): SplatMeta holds an nlohmann::json (splat_meta.h).
struct SplatRecord {
    api::SplatMeta meta;
    core::SplatWeights weights;
    std::string height;                      // rules: the height texton's id
    std::vector<std::string> weight_uploads; // image weights: the images as uploaded
};

// How weight images are decoded, at creation (which also caps them at --max-pixels) and at load:
// every channel (RGBA = four layers), at most 4,194,304 pixels (core::kMaxSplatWeightPixels),
// any format the uploads take (`formats` narrows it at creation).
DecodeLimits splat_weight_limits(const std::vector<std::string>& formats = {});

// Layer k's weights: channel k of `weights` (R, G, B, A), then for layers 5 to 8 channel k - 4
// of `weights2`; channels past the last layer (A under three layers) are left out. The images are
// decoded one at a time into the layers' planes, so at most one decoded image is held beside them.
Result<core::Image> decode_splat_weights(const std::vector<std::string_view>& encoded,
                                         const DecodeLimits& limits, int layers);

// Content address: the version, the layer ids in order and the canonical weights JSON.
std::string splat_id(const std::vector<std::string>& textons, const nlohmann::json& weights);

Result<bool> write_splat_files(const std::string& dir, const SplatRecord& record);
// not_found when there is none; io when its files are damaged or fail today's rules.
Result<SplatRecord> read_splat_files(const std::string& dir, const std::string& id);

} // namespace textond::io
