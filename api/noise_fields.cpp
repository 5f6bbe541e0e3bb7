#include "api/noise_fields.h"

#include "core/grid_poisson.h"
#include "core/material_set.h"

#include <cstdio>

namespace textond::api {

namespace {

ApiError invalid(std::string message) {
    return {"invalid_parameter", std::move(message)};
}

// "1" and "200", not std::to_string's "1.000000".
std::string number_text(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

std::string shown(const std::string& text) {
    return "'" + text.substr(0, 40) + "'";
}

std::optional<ApiError> read_seed(const std::string& s, NoiseParams& out) {
    auto v = parse_u64(s);
    if (!v)
        return invalid("seed must be an unsigned 64-bit integer, not " + shown(s) +
                       canonical_hint(s));
    out.seed = *v;
    return std::nullopt;
}

std::optional<ApiError> read_mni(const std::string& s, NoiseParams& out) {
    auto v = parse_decimal(s);
    if (!v || *v < core::noise::kMinMni || *v > core::noise::kMaxMni)
        return invalid("mni (mean number of impacts per pixel) must be a number in [" +
                       number_text(core::noise::kMinMni) + ", " +
                       number_text(core::noise::kMaxMni) + "], not " + shown(s) +
                       canonical_hint(s));
    out.mni = *v;
    return std::nullopt;
}

std::optional<ApiError> read_marginals(const std::string& s, NoiseParams& out) {
    if (s != "gaussian" && s != "exemplar")
        return invalid("marginals must be gaussian or exemplar, not " + shown(s));
    out.exemplar_marginals = s == "exemplar";
    return std::nullopt;
}

std::optional<ApiError> read_map(const std::string& s, NoiseParams& out) {
    bool known = s == core::kNormalMap || s == core::kLitMap;
    for (const char* n : core::kMapNames) known = known || s == n;
    if (!known)
        return invalid("map must be albedo, height, roughness, ao, metallic, normal or lit, not " +
                       shown(s));
    out.map.name = s;
    return std::nullopt;
}

std::optional<ApiError> read_strength(const std::string& s, NoiseParams& out) {
    auto v = parse_decimal(s);
    if (!v || !(*v > 0.0) || *v > core::kMaxNormalStrength)
        return invalid("strength (texels a height step of 1 spans) must be a number in (0, " +
                       number_text(core::kMaxNormalStrength) + "], not " + shown(s) +
                       canonical_hint(s));
    out.map.strength = *v;
    return std::nullopt;
}

std::optional<ApiError> read_light(const std::string& s, NoiseParams& out) {
    const auto comma = s.find(',');
    const auto az = parse_decimal(s.substr(0, comma));
    const auto el = comma == std::string::npos ? std::nullopt : parse_decimal(s.substr(comma + 1));
    if (!az || !el || *az < 0.0 || *az > 360.0 || !(*el > 0.0) || *el > 90.0)
        return invalid("light must be AZIMUTH,ELEVATION in degrees (azimuth 0..360 counter-"
                       "clockwise from +x, elevation in (0, 90]), not " +
                       shown(s));
    out.map.azimuth = *az;
    out.map.elevation = *el;
    return std::nullopt;
}

std::optional<ApiError> read_encoding(const std::string& s, NoiseParams& out) {
    out.map.encoding = core::parse_elevation_encoding(s);
    if (!out.map.encoding) return invalid("encoding must be terrarium or mapbox, not " + shown(s));
    return std::nullopt;
}

std::optional<ApiError> read_height_scale(const std::string& s, NoiseParams& out) {
    auto v = parse_decimal(s);
    if (!v || !(*v > 0.0) || *v > kMaxHeightScale)
        return invalid("height_scale (metres for the height map's 0..1) must be a number in (0, " +
                       number_text(kMaxHeightScale) + "], not " + shown(s) + canonical_hint(s));
    out.map.height_scale = *v;
    return std::nullopt;
}

constexpr unsigned kImages = kTileRoute | kRegionRoute | kTileableRoute;
constexpr unsigned kMixes = kMixTileRoute | kMixRegionRoute;
constexpr unsigned kSurfaces = kSurfaceRoute | kMeshRoute;

} // namespace

// Seed and mni are always written: a TileJSON's template states the noise it shows.
const std::array<NoiseField, 8> kNoiseFields = {{
    {"seed", kImages | kMixes | kReportRoute | kSurfaces, read_seed,
     [](const NoiseParams& p) { return std::to_string(p.seed); }},
    {"mni", kImages | kMixes | kReportRoute | kKitRoute | kSurfaces, read_mni,
     [](const NoiseParams& p) { return query_text(p.mni); }},
    {"marginals", kImages | kMixes | kSurfaces, read_marginals,
     [](const NoiseParams& p) { return std::string(p.exemplar_marginals ? "exemplar" : ""); }},
    {"map", kImages | kSurfaces, read_map, [](const NoiseParams& p) { return p.map.name; }},
    {"strength", kImages | kMeshRoute, read_strength,
     [](const NoiseParams& p) {
         return p.map.uses_normals() ? query_text(p.map.strength) : std::string();
     }},
    {"light", kImages | kMeshRoute, read_light,
     [](const NoiseParams& p) {
         return p.map.name == core::kLitMap
                    ? query_text(p.map.azimuth) + "," + query_text(p.map.elevation)
                    : std::string();
     }},
    // Elevation tiles: the web-map and game tiles (and export) of a set's height map.
    {"encoding", kTileRoute, read_encoding,
     [](const NoiseParams& p) {
         return p.map.encoding ? std::string(core::elevation_encoding_name(*p.map.encoding))
                               : std::string();
     }},
    {"height_scale", kTileRoute, read_height_scale,
     [](const NoiseParams& p) {
         return p.map.encoding ? query_text(p.map.height_scale) : std::string();
     }},
}};

std::vector<std::string> noise_field_names(NoiseRoute route) {
    std::vector<std::string> names;
    for (const NoiseField& f : kNoiseFields)
        if (f.routes & route) names.emplace_back(f.name);
    return names;
}

std::optional<ApiError> read_noise_fields(const Query& q, NoiseRoute route, NoiseParams& out) {
    for (const NoiseField& f : kNoiseFields)
        if (auto it = q.find(f.name); (f.routes & route) && it != q.end())
            if (auto e = f.read(it->second, out)) return e;
    // Every mesh is lit, and a set's mesh shows its relief by default: light and strength need
    // no map there.
    const bool mesh = route == kMeshRoute;
    if (q.count("strength") && !out.map.uses_normals() && !(mesh && out.map.name.empty()))
        return invalid("strength applies to map=normal and map=lit only");
    if (q.count("light") && out.map.name != core::kLitMap && !mesh)
        return invalid("light applies to map=lit only");
    if (out.map.encoding && out.map.name != core::kHeightMap)
        return invalid("encoding applies to map=height only: elevation tiles of a material "
                       "set's height map");
    if (q.count("height_scale") && !out.map.encoding)
        return invalid("height_scale applies to elevation tiles only (encoding=terrarium or "
                       "encoding=mapbox)");
    return std::nullopt;
}

std::string noise_query(const NoiseParams& p, NoiseRoute route) {
    std::string query;
    for (const NoiseField& f : kNoiseFields) {
        if (!(f.routes & route)) continue;
        const std::string value = f.write(p);
        if (!value.empty()) query += (query.empty() ? "" : "&") + std::string(f.name) + "=" + value;
    }
    return query;
}

} // namespace textond::api
