#pragma once
// POST /v1/sign: image URLs signed for a holder of the server's --api-key, so that a page (or any
// client without the signing key) can hand out URLs of a server run with --url-signing-key.
// Body: {"urls": ["/v1/textons/ID/tilejson.json?seed=3", ...], "expires_in": 86400}.
#include "api/requests.h"

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace textond::api {

inline constexpr std::size_t kMaxSignUrls = 100;
inline constexpr std::size_t kMaxSignUrlBytes = 4096;
inline constexpr std::int64_t kMaxSignSeconds = 365LL * 86400;
// The largest body such a request needs (every URL at its longest, twice over for escapes): a
// larger one is refused before it is read, so one token of a 32 MB body (which the JSON lexer
// holds several times over) costs nothing.
inline constexpr std::size_t kMaxSignBodyBytes = kMaxSignUrls * kMaxSignUrlBytes * 2 + 4096;

struct SignRequest {
    std::vector<std::string> urls;
    std::int64_t expires_in = 3600; // seconds; the URLs stop working then
};

// invalid_body for anything else than that object; one to kMaxSignUrls URLs of at most
// kMaxSignUrlBytes each (paths with their query, or absolute URLs); expires_in in
// 1..kMaxSignSeconds.
std::optional<ApiError> parse_sign(std::string_view body, SignRequest& out);

} // namespace textond::api
