#pragma once
// A command's INPUT: a texton file written by `textond analyze`, or an exemplar analysed on the
// spot with the analysis options.
#include "core/result.h"
#include "core/texton.h"
#include "server/cli/args.h"

#include <string>

namespace textond::cli {

Result<core::Texton> load_or_analyze(const std::string& input, const Args& args);

} // namespace textond::cli
