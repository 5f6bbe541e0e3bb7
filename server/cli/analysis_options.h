#pragma once
// Options shared by every command that runs an analysis (analyze, synth --method dsn, bench).
#include "core/result.h"
#include "core/texton_analysis.h"
#include "server/cli/args.h"
#include "server/cli/commands.h"
#include "server/io/image_io.h"

#include <set>
#include <string>
#include <variant>

namespace textond::cli {

extern const std::set<std::string> kAnalysisOptions; // take a value
extern const std::set<std::string> kAnalysisFlags;   // --no-periodic
extern const char* kAnalysisHelp;

Result<core::AnalysisParams> analysis_params_from(const Args& a);

// What analyze, synth and render share: the analysis options and flags plus the command's own,
// --help (the command's text, then the analysis options'), exactly one INPUT (any number with
// `many_inputs`: the command checks them) and, when `needs_output`, an -o OUT.png|OUT.exr.
// Returns the arguments, or the exit code to return now.
std::variant<Args, int> parse_input_command(const Argv& argv, const std::string& name,
                                            const char* help, const char* input_name,
                                            bool needs_output,
                                            const std::set<std::string>& own_options,
                                            const std::set<std::string>& own_flags,
                                            bool many_inputs = false);
Result<io::DecodeLimits> decode_limits_from(const Args& a);
// The encoding of -o OUT (by extension), 16-bit with --png16 (which needs a .png).
Result<io::Encoding> output_encoding_from(const Args& a);

// Progress to stderr once an analysis has run for a second, then about once a second.
core::ProgressFn progress_reporter(const std::string& label,
                                   const std::string& unit = "projection");

} // namespace textond::cli
