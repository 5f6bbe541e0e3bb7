#pragma once
// A small command-line parser: positional arguments, `--name value` options and `--flag`s.
// Unknown options are errors (a typo must not silently fall back to a default).
#include "core/result.h"

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace textond::cli {

struct Args {
    std::vector<std::string> positional;
    std::map<std::string, std::string> options;
    std::set<std::string> flags;

    bool has(const std::string& name) const { return options.count(name) || flags.count(name); }
    std::string get(const std::string& name, const std::string& fallback = "") const;
    Result<long long> get_int(const std::string& name, long long fallback, long long lo,
                              long long hi) const;
    Result<std::uint64_t> get_u64(const std::string& name, std::uint64_t fallback) const;
    Result<double> get_double(const std::string& name, double fallback, double lo, double hi) const;
};

// `value_options` take a value; `flag_options` do not. Names include the dashes ("--size");
// "-o" is accepted as an alias of "--output". A value option given twice: the last wins (serve's
// flags override its TEXTOND_* environment), or, with `each_once` (options that are a URL's
// fields, as export's), an error.
Result<Args> parse_args(const std::vector<std::string>& argv,
                        const std::set<std::string>& value_options,
                        const std::set<std::string>& flag_options, bool each_once = false);

} // namespace textond::cli
