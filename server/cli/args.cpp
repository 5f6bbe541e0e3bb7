#include "server/cli/args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace textond::cli {

std::string Args::get(const std::string& name, const std::string& fallback) const {
    const auto it = options.find(name);
    return it == options.end() ? fallback : it->second;
}

Result<long long> Args::get_int(const std::string& name, long long fallback, long long lo,
                                long long hi) const {
    const auto it = options.find(name);
    if (it == options.end()) return fallback;
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(it->second.c_str(), &end, 10);
    if (errno != 0 || end == it->second.c_str() || *end != '\0')
        return make_error(ErrorCode::invalid_argument,
                          name + " expects an integer, got '" + it->second + "'");
    if (v < lo || v > hi)
        return make_error(ErrorCode::invalid_argument, name + " must be in " + std::to_string(lo) +
                                                           ".." + std::to_string(hi) + ", got " +
                                                           it->second);
    return v;
}

Result<std::uint64_t> Args::get_u64(const std::string& name, std::uint64_t fallback) const {
    const auto it = options.find(name);
    if (it == options.end()) return fallback;
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(it->second.c_str(), &end, 10);
    if (errno != 0 || end == it->second.c_str() || *end != '\0' || it->second[0] == '-')
        return make_error(ErrorCode::invalid_argument,
                          name + " expects an integer in 0..2^64-1, got '" + it->second + "'");
    return static_cast<std::uint64_t>(v);
}

Result<double> Args::get_double(const std::string& name, double fallback, double lo,
                                double hi) const {
    const auto it = options.find(name);
    if (it == options.end()) return fallback;
    char* end = nullptr;
    const double v = std::strtod(it->second.c_str(), &end);
    if (end == it->second.c_str() || *end != '\0' || !std::isfinite(v))
        return make_error(ErrorCode::invalid_argument,
                          name + " expects a number, got '" + it->second + "'");
    if (v < lo || v > hi)
        return make_error(ErrorCode::invalid_argument, name + " must be in [" + std::to_string(lo) +
                                                           ", " + std::to_string(hi) + "], got " +
                                                           it->second);
    return v;
}

Result<Args> parse_args(const std::vector<std::string>& argv,
                        const std::set<std::string>& value_options,
                        const std::set<std::string>& flag_options, bool each_once) {
    Args a;
    for (std::size_t i = 0; i < argv.size(); ++i) {
        std::string s = argv[i];
        if (s == "-o") s = "--output";
        if (s.size() > 1 && s[0] == '-') {
            std::string value;
            const auto eq = s.find('=');
            const bool inline_value = s.rfind("--", 0) == 0 && eq != std::string::npos;
            if (inline_value) {
                value = s.substr(eq + 1);
                s = s.substr(0, eq);
            }
            if (flag_options.count(s)) {
                if (inline_value)
                    return make_error(ErrorCode::invalid_argument, s + " takes no value");
                a.flags.insert(s);
            } else if (value_options.count(s)) {
                if (!inline_value) {
                    if (i + 1 >= argv.size())
                        return make_error(ErrorCode::invalid_argument, s + " needs a value");
                    value = argv[++i];
                }
                // One value an option: "--encoding terrarium --encoding mapbox" is refused, as
                // a URL naming a field twice is.
                if (each_once && a.options.count(s))
                    return make_error(ErrorCode::invalid_argument, s + " is given twice");
                a.options[s] = value;
            } else {
                return make_error(ErrorCode::invalid_argument, "unknown option " + s);
            }
        } else {
            a.positional.push_back(s);
        }
    }
    return a;
}

} // namespace textond::cli
