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

} // namespace textond::api
