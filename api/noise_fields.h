#pragma once
// The noise parameters of the image routes, one row each (kNoiseFields): the routes that take
// it, how its text is read (spelling, range, message) and how a value is written back into a URL.
// The routes' allow-lists (requests.cpp), the image cache's keys (ImageService::key), TileJSON's
// tile templates and `textond export`'s options are all made from this table, and
// tests/api/contract_test.py holds api/openapi.yaml to it route by route. A new parameter is a
// row here, a member of NoiseParams, and its use where the noise is made.
#include "api/requests.h"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace textond::api {

// The routes that take noise parameters: bits of NoiseField::routes.
enum NoiseRoute : unsigned {
    kTileRoute = 1U << 0,     // tiles/, map/, tilejson.json and `textond export`
    kRegionRoute = 1U << 1,   // region.{format}
    kTileableRoute = 1U << 2, // tileable.{format}
    kReportRoute = 1U << 3,   // spectrum.png, quality.png, quality.json
    kKitRoute = 1U << 4,      // kit.tar
    kSurfaceRoute = 1U << 5,  // POST surface
    kMeshRoute = 1U << 6,     // POST mesh.png
    kMixTileRoute = 1U << 7,  // a mix's or splat's tiles/, map/ and tilejson.json: no maps
    kMixRegionRoute = 1U << 8,
};

struct NoiseField {
    const char* name;
    unsigned routes;
    // The field's text into `out`; a refusal names the field, its range and, for a number spelled
    // otherwise, its one spelling.
    std::optional<ApiError> (*read)(const std::string& text, NoiseParams& out);
    // Its value as URL text; "" where a URL leaves the default out.
    std::string (*write)(const NoiseParams& p);
};

extern const std::array<NoiseField, 8> kNoiseFields;

// The fields `route` takes, in table order.
std::vector<std::string> noise_field_names(NoiseRoute route);
// Reads the fields of `q` that `route` takes into `out`, then the rules between them (strength
// and light need a view that uses normals, except on meshes). The caller's allow-list has
// already refused the fields `route` does not take.
std::optional<ApiError> read_noise_fields(const Query& q, NoiseRoute route, NoiseParams& out);
// "seed=0&mni=30&map=normal&strength=1": the fields of `p` that `route` takes and a URL writes,
// in table order, every number in its one spelling (query_text). TileJSON's templates and the
// image cache's keys.
std::string noise_query(const NoiseParams& p, NoiseRoute route);

} // namespace textond::api
