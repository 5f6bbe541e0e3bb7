#pragma once
// The tables of `textond bench analyze` on large exemplars (bench_analyze.cpp).
#include "core/image.h"
#include "core/result.h"
#include "core/texton_analysis.h"

#include <filesystem>
#include <vector>

namespace textond::cli {

// `src` repeated to w x h.
core::Image tiled(const core::Image& src, int w, int h);

// `repeat` analyses of `u`: the median time, the last RME and texton, and the peak resident
// memory over what was resident at the start.
struct AnalysisRun {
    double ms = 0;
    double verdict_ms = 0; // the micro/macro verdict's share (timings.shape_ms), median
    double rme = 0;
    long peak_mib = 0;
    core::Texton texton;
};
Result<AnalysisRun> analyse(const core::Image& u, const core::AnalysisParams& p, int repeat);

// Sizes 512² to 4096² of a window of `sand`'s texton noise: time, ratio to 1024², peak memory
// and RME; with `compare`, the whole exemplar's analysis beside each.
Result<bool> scaling_table(const core::Image& sand, int repeat, bool compare);
// Every photo upscaled and tiled to 4096²: the windowed analysis against the whole one (slow:
// about 30 s of the whole analysis a row on 2 cores).
Result<bool> photo_table(const std::vector<std::filesystem::path>& files);

} // namespace textond::cli
