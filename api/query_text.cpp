#include "api/query_text.h"

#include <algorithm>
#include <string>

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

} // namespace textond::api
