#include "api/query_text.h"

#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

namespace textond::api {

std::optional<ApiError> check_query_text(std::string_view query) {
    std::size_t at = 0;
    while (at < query.size()) {
        const std::size_t amp = std::min(query.find('&', at), query.size());
        const std::string_view item = query.substr(at, amp - at);
        if (std::count(item.begin(), item.end(), '=') > 1)
            return ApiError{"invalid_parameter",
                            "query item '" + std::string(item.substr(0, 60)) +
                                "' has more than one '=' (write one in a value as %3D)"};
        at = amp + 1;
    }
    return std::nullopt;
}

namespace {

bool unreserved(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
           c == '.' || c == '_' || c == '~';
}

int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
}

ApiError non_canonical(const std::string& why) {
    return ApiError{"non_canonical_url", why + ": each answer has one URL, so that caches keep "
                                               "one copy of it"};
}

// The target's percent-encodings: uppercase, and only of what must be encoded.
std::optional<ApiError> check_percent_encodings(std::string_view target) {
    for (std::size_t i = 0; i < target.size(); ++i) {
        if (target[i] != '%') continue;
        const int hi = i + 1 < target.size() ? hex_value(target[i + 1]) : -1;
        const int lo = i + 2 < target.size() ? hex_value(target[i + 2]) : -1;
        if (hi < 0 || lo < 0)
            return ApiError{"invalid_parameter", "a '%' in the URL is not followed by two hex "
                                                 "digits (write a '%' as %25)"};
        const std::string spelled(target.substr(i, 3));
        const char decoded = static_cast<char>(hi * 16 + lo);
        if (unreserved(decoded))
            return non_canonical("'" + spelled + "' in the URL encodes '" +
                                 std::string(1, decoded) + "': write '" + std::string(1, decoded) +
                                 "' itself");
        if (std::islower(static_cast<unsigned char>(target[i + 1])) ||
            std::islower(static_cast<unsigned char>(target[i + 2]))) {
            std::string upper = spelled;
            for (char& c : upper)
                c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
            std::string why = "'";
            why.append(spelled).append("' in the URL: write '").append(upper);
            return non_canonical(why + "' (uppercase hex digits)");
        }
        i += 2;
    }
    return std::nullopt;
}

} // namespace

std::optional<ApiError> check_target_text(std::string_view target) {
    if (target.find('#') != std::string_view::npos)
        return non_canonical("a '#' in the request: a fragment is the client's, never sent");
    const std::size_t q = target.find('?');
    // No path here needs a percent-encoding (ids are hex, the rest plain words and numbers):
    // '%2F' or '%40' would be routed as '/' and '@', another spelling of one answer.
    if (const std::size_t pct = target.substr(0, q).find('%'); pct != std::string_view::npos)
        return non_canonical("'" + std::string(target.substr(pct, 3)) +
                             "' in the path: paths here are written without percent-encoding");
    if (auto e = check_percent_encodings(target)) return e;
    if (q == std::string_view::npos) return std::nullopt;
    const std::string_view query = target.substr(q + 1);
    if (auto e = check_query_text(query)) return e;
    if (query.empty()) return non_canonical("an empty query: leave the '?' out");
    std::vector<std::string_view> names;
    std::size_t at = 0;
    for (;;) {
        const std::size_t amp = std::min(query.find('&', at), query.size());
        const std::string_view item = query.substr(at, amp - at);
        if (item.empty())
            return non_canonical("the query has an empty item (a leading, trailing or doubled "
                                 "'&')");
        const std::string_view name = item.substr(0, item.find('='));
        if (std::find(names.begin(), names.end(), name) != names.end())
            return ApiError{"invalid_parameter",
                            "parameter '" + std::string(name.substr(0, 40)) +
                                "' is given more than once (even with one value: each answer "
                                "has one URL, so that caches keep one copy of it)"};
        names.push_back(name);
        if (amp == query.size()) break;
        at = amp + 1;
    }
    return std::nullopt;
}

} // namespace textond::api
