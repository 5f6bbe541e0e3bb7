#pragma once
// JSON request bodies read through nlohmann's SAX interface, so that what a body may make the
// server allocate is bounded before any document is built: a 32 MB "[[[...]]]" once built a
// tree of 1.2 GB, and glibc kept most of it after the request.
#include "api/requests.h"

#include <cstddef>
#include <optional>
#include <string_view>
#include <vector>

namespace textond::api {

// The body is one JSON value nested at most `max_depth` arrays/objects deep, with at most
// `max_values` values in all (containers and keys count). Checked without building it.
std::optional<ApiError> check_json_bounds(std::string_view body, int max_depth,
                                          std::size_t max_values);

// {"points": [[x, y, z], ...], "normals": [[x, y, z], ...]} straight into floats (three a
// point), at most `max_points`; any other field, shape or count is invalid_body, and more points
// payload_too_large.
std::optional<ApiError> parse_surface_json(std::string_view body, std::size_t max_points,
                                           std::vector<float>& points, std::vector<float>& normals);

} // namespace textond::api
