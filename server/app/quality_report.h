#pragma once
// A texton's quality report, without HTTP: the exemplar beside windows of its
// noise with Gaussian and with the exemplar's marginals, their power spectra, per-channel
// histograms, and the numbers (RME, phase coherence and verdict, 1-D Wasserstein distances) as
// JSON and as one PNG.
#include "api/texton_meta.h"
#include "core/image.h"

#include <nlohmann/json.hpp>

namespace textond::app {

// An nlohmann::json member's noexcept move reads as a throw to clang-tidy (as api/mix_meta.h).
// NOLINTNEXTLINE(bugprone-exception-escape)
struct QualityReport {
    nlohmann::json json;
    core::Image png; // RGB, for people: images, spectra, histograms
};

// `exemplar`: the exemplar's centre crop; `gaussian` and `restored` (empty when the texton keeps no
// marginals): level-0 windows of its noise of the same size.
QualityReport quality_report(const api::TextonMeta& meta, const core::Image& exemplar,
                             const core::Image& gaussian, const core::Image& restored);

} // namespace textond::app
