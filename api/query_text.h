#pragma once
// The raw query of a URL, before the HTTP library splits it into fields. No HTTP here.
#include "api/requests.h"

#include <optional>
#include <string_view>

namespace textond::api {

// Refuses a query item with more than one literal '=' ("seed=1=5", "seed=1;mni=2"): the HTTP
// library keeps only what follows the last one, so the URL would silently name another image
// than it spells. A '=' inside a value is written %3D.
std::optional<ApiError> check_query_text(std::string_view query);

// One URL for one answer: caches key on the URL as sent, so every spelling of a
// request that names the same answer would be its own entry. Refused, with the canonical
// form in the message: any percent-encoding in the path (none is needed there), a fragment, a
// percent-encoded unreserved character (ALPHA, DIGIT, "-", ".", "_", "~") or lowercase hex
// digits of a percent-encoding in the query; in the query, an empty
// item ("&&", a leading or trailing "&") or an empty query ("?" alone): non_canonical_url; a field
// named twice, even with one value: invalid_parameter, as every route's own check says.
std::optional<ApiError> check_target_text(std::string_view target);

} // namespace textond::api
