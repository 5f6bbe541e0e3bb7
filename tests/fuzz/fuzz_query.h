#pragma once
// The fuzz targets' query splitter: "a=b&c=d" as the server splits a query after percent-decoding
// (bytes taken as they come), at most 32 items.
#include "api/requests.h"

#include <string>
#include <string_view>

namespace textond::test {

// `keep_empty`: an empty item becomes a parameter with an empty name (the parsers must refuse
// it); otherwise it is skipped, as the server's own splitting does.
inline api::Query query_of(std::string_view s, bool keep_empty) {
    api::Query q;
    std::size_t pos = 0;
    while (pos <= s.size() && q.size() < 32) {
        std::size_t end = s.find('&', pos);
        if (end == std::string_view::npos) end = s.size();
        const std::string_view item = s.substr(pos, end - pos);
        const std::size_t eq = item.find('=');
        if (keep_empty || !item.empty())
            q.emplace(std::string(item.substr(0, eq)),
                      eq == std::string_view::npos ? "" : std::string(item.substr(eq + 1)));
        pos = end + 1;
    }
    return q;
}

} // namespace textond::test
