#include "server/cli/export_plan.h"

#include "api/requests.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace textond::cli {

namespace {

Error bad(const std::string& message) {
    return {ErrorCode::invalid_argument, message};
}

double longitude(double x, double world) {
    return x / world * 360.0 - 180.0;
}

// The inverse Web Mercator of a row: y = 0 is the north edge (85.05 degrees).
double latitude(double y, double world) {
    const double pi = std::acos(-1.0);
    return std::atan(std::sinh(pi * (1.0 - 2.0 * y / world))) * 180.0 / pi;
}

} // namespace

std::uint64_t ExportPlan::count() const {
    std::uint64_t n = 0;
    for (const Zoom& z : zooms) n += z.count();
    return n;
}

std::vector<TileAddress> ExportPlan::tiles() const {
    std::vector<TileAddress> out;
    out.reserve(count());
    for (const Zoom& z : zooms)
        for (std::uint32_t y = z.y0; y <= z.y1; ++y)
            for (std::uint32_t x = z.x0; x <= z.x1; ++x) out.push_back({z.z, x, y});
    return out;
}

std::vector<double> ExportPlan::bounds_degrees() const {
    const double w = static_cast<double>(world());
    return {longitude(static_cast<double>(x0), w), latitude(static_cast<double>(y1), w),
            longitude(static_cast<double>(x1), w), latitude(static_cast<double>(y0), w)};
}

int ExportPlan::center_zoom() const {
    const double side = static_cast<double>(std::max(x1 - x0, y1 - y0));
    for (int z = max_zoom; z > min_zoom; --z)
        if (side / std::ldexp(1.0, kExportMaxZoom - z) <= 1024.0) return z;
    return min_zoom;
}

Result<ExportPlan> make_export_plan(const std::string& zooms, const std::string& bbox,
                                    int tile_size) {
    ExportPlan p;
    p.tile_size = tile_size;
    const auto dash = zooms.find('-');
    const auto lo = api::parse_i64(zooms.substr(0, dash));
    const auto hi = dash == std::string::npos ? lo : api::parse_i64(zooms.substr(dash + 1));
    if (!lo || !hi || *lo < 0 || *hi > kExportMaxZoom || *lo > *hi)
        return bad("--zooms is A-B (or A) with 0 <= A <= B <= " + std::to_string(kExportMaxZoom) +
                   " (map zooms: level = 24 - zoom), not '" + zooms + "'");
    p.min_zoom = static_cast<int>(*lo);
    p.max_zoom = static_cast<int>(*hi);

    std::vector<std::int64_t> v;
    if (!bbox.empty() && bbox.back() == ',')
        return bad("--bbox is X0,Y0,X1,Y1 in texels, not '" + bbox + "'");
    std::stringstream in(bbox);
    for (std::string part; std::getline(in, part, ',');) {
        const auto n = api::parse_i64(part);
        if (!n) return bad("--bbox is X0,Y0,X1,Y1 in texels (integers), not '" + bbox + "'");
        v.push_back(*n);
    }
    if (v.size() != 4) return bad("--bbox is X0,Y0,X1,Y1 in texels, not '" + bbox + "'");
    p.x0 = v[0], p.y0 = v[1], p.x1 = v[2], p.y1 = v[3];
    if (p.x0 < 0 || p.y0 < 0 || p.x1 > p.world() || p.y1 > p.world() || p.x0 >= p.x1 ||
        p.y0 >= p.y1)
        return bad("--bbox must satisfy 0 <= X0 < X1 <= " + std::to_string(p.world()) +
                   " and the same for Y (an archive numbers tiles from 0 to 2^zoom - 1; zoom "
                   "0's tile covers " +
                   std::to_string(p.world()) + " texels a side)");
    for (int z = p.min_zoom; z <= p.max_zoom; ++z) {
        const std::int64_t span = std::int64_t{tile_size} << (kExportMaxZoom - z); // texels
        p.zooms.push_back({z, static_cast<std::uint32_t>(p.x0 / span),
                           static_cast<std::uint32_t>((p.x1 - 1) / span),
                           static_cast<std::uint32_t>(p.y0 / span),
                           static_cast<std::uint32_t>((p.y1 - 1) / span)});
        if (p.count() > kExportMaxTiles)
            return bad("the export would hold more than " + std::to_string(kExportMaxTiles) +
                       " tiles: narrow --bbox or --zooms");
    }
    return p;
}

} // namespace textond::cli
