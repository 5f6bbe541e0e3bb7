#pragma once
// Options shared by every command that runs an analysis (analyze, synth --method dsn, bench).
#include "core/result.h"
#include "core/texton_analysis.h"
#include "server/cli/args.h"
#include "server/io/image_io.h"

#include <set>
#include <string>

namespace textond::cli {

extern const std::set<std::string> kAnalysisOptions; // take a value
extern const std::set<std::string> kAnalysisFlags;   // --no-periodic
extern const char* kAnalysisHelp;

Result<core::AnalysisParams> analysis_params_from(const Args& a);
Result<io::DecodeLimits> decode_limits_from(const Args& a);

// Progress to stderr once an analysis has run for a second, then about once a second.
core::ProgressFn progress_reporter(const std::string& label);

} // namespace textond::cli
