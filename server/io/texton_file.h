#pragma once
// The texton file (api/TEXTON_FORMAT.md): an OpenEXR image of the float32 coefficients (r x r,
// channels Y or R,G,B, ZIP compression, lossless) whose header attribute "textond:meta" holds the
// metadata JSON. Any EXR viewer shows the coefficients; reading it back is bit-exact.
#include "api/texton_meta.h"
#include "core/image.h"
#include "core/material_set.h"
#include "core/result.h"
#include "core/texton.h"
#include "core/texton_analysis.h"

#include <string>

namespace textond::io {

inline constexpr const char* kMetaAttribute = "textond:meta";
// The exemplar's marginals (core/marginals.h) as JSON, when the texton has them.
inline constexpr const char* kMarginalsAttribute = "textond:marginals";

struct TextonRecord {
    core::Texton texton;
    api::TextonMeta meta;
};

// Content address: sha256 over the algorithm version, the decoded exemplar (size, channels,
// float32 pixels) and the canonical parameters.
// A material set's id also covers its maps' names, channels and bits.
std::string texton_id(const core::Image& exemplar, const core::AnalysisParams& params,
                      const std::vector<api::MapMeta>& maps = {});

// sha256 of the coefficients' float32 bytes (planar), stored in the metadata and checked on load.
std::string coefficients_sha256(const core::Texton& t);

TextonRecord make_record(const core::Image& exemplar, const core::AnalysisParams& params,
                         const core::AnalysisResult& result);

// A material set's record: `stacked` holds the maps side by side, `maps` their names, channels
// and bits (ranges and RMEs are filled in here).
TextonRecord make_set_record(const core::Image& stacked, std::vector<api::MapMeta> maps,
                             const core::AnalysisParams& params, const core::SetAnalysis& set);

// The file's bytes, as write_texton_file writes them (the shared store keeps these).
Result<std::string> texton_file_bytes(const TextonRecord& record);
Result<bool> write_texton_file(const std::string& path, const TextonRecord& record);
Result<TextonRecord> read_texton_file(const std::string& path);

// The authors' viewer format, `.texton` version 1: "TEXTON", version, order, mean RGB, width and
// height of the coefficients with a one-texel zero frame, then "r g b" per texel, rows from the
// bottom, then a line naming the original image. Grey textons are written as R = G = B.
std::string texton_v1_text(const TextonRecord& record, const std::string& name);

} // namespace textond::io
