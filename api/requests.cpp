#include "api/requests.h"

#include "api/json_body.h"
#include "api/noise_fields.h"

#include "core/grid_poisson.h"
#include "core/noise_levels.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <vector>

namespace textond::api {

namespace {

ApiError bad(std::string code, std::string message) {
    return {std::move(code), std::move(message)};
}

// Refuses fields the endpoint does not know and fields given twice: a typo or an ambiguous URL
// must not silently fall back to a default (and one image must have one URL, for caches). The
// endpoint takes its own fields (`own`) and the noise fields kNoiseFields gives `route`.
std::optional<ApiError> check_fields(const Query& q, std::initializer_list<const char*> own,
                                     unsigned route = 0) {
    std::vector<std::string> known(own.begin(), own.end());
    if (route)
        for (std::string& n : noise_field_names(static_cast<NoiseRoute>(route)))
            known.push_back(std::move(n));
    for (auto it = q.begin(); it != q.end(); ++it) {
        if (std::find(known.begin(), known.end(), it->first) == known.end()) {
            std::string list;
            for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
            return bad("unknown_parameter", "unknown parameter '" + it->first +
                                                "' (this endpoint takes " +
                                                (list.empty() ? "none" : list) + ")");
        }
        if (q.count(it->first) > 1)
            return bad("invalid_parameter",
                       "parameter '" + it->first + "' is given more than once");
    }
    return std::nullopt;
}

// "1" and "200", not std::to_string's "1.000000".
std::string number_text(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

const std::string* field(const Query& q, const char* name) {
    auto it = q.find(name);
    return it == q.end() ? nullptr : &it->second;
}

std::optional<ApiError> int_field(const Query& q, const char* name, std::int64_t lo,
                                  std::int64_t hi, std::int64_t& out) {
    const std::string* s = field(q, name);
    if (!s) return std::nullopt;
    auto v = parse_i64(*s);
    if (!v || *v < lo || *v > hi)
        return bad("invalid_parameter", std::string(name) + " must be an integer in [" +
                                            std::to_string(lo) + ", " + std::to_string(hi) +
                                            "], not '" + s->substr(0, 40) + "'" +
                                            canonical_hint(*s));
    out = *v;
    return std::nullopt;
}

// A number of a form or query field in its one spelling (parse_decimal: no '+', leading zeros,
// spaces, hex, exponent, '-0' or trailing fractional zeros), as a tile's numbers are: a mix's or
// splat's placement names its id, so "07", "+7" and "7." would be other ids for one placement.
std::optional<ApiError> decimal_field(const Query& q, const char* name, double& out) {
    const std::string* s = field(q, name);
    if (!s) return std::nullopt;
    auto v = parse_decimal(*s);
    if (!v)
        return bad("invalid_parameter", std::string(name) +
                                            " must be a finite number in its one "
                                            "spelling, not '" +
                                            s->substr(0, 40) + "'" + canonical_hint(*s));
    out = *v;
    return std::nullopt;
}

std::optional<ApiError> format_of(std::string_view ext, ImageFormat& out) {
    auto f = parse_image_format(ext);
    if (!f)
        return bad("invalid_format", "image format must be png, png16, exr, webp or avif, not '" +
                                         std::string(ext.substr(0, 20)) + "'");
    out = *f;
    return std::nullopt;
}

// quality=: lossy WebP and AVIF only.
std::optional<ApiError> quality_of(const Query& q, ImageFormat f, int& out) {
    const std::string* s = field(q, "quality");
    if (!s) return std::nullopt;
    auto v = parse_i64(*s);
    if (!v || *v < 1 || *v > 100)
        return bad("invalid_parameter", "quality must be an integer in [1, 100], not '" +
                                            s->substr(0, 40) + "'" + canonical_hint(*s));
    if (f != ImageFormat::webp && f != ImageFormat::avif)
        return bad("invalid_parameter",
                   "quality applies to .webp and .avif (PNG and EXR are lossless)");
    out = static_cast<int>(*v);
    return std::nullopt;
}

std::optional<ApiError> level_of(std::string_view z, int& out) {
    auto v = parse_i64(z);
    if (!v)
        return bad("invalid_parameter", "z must be an integer, not '" +
                                            std::string(z.substr(0, 40)) + "'" + canonical_hint(z));
    if (*v < core::noise::kMinLevel || *v > core::noise::kMaxLevel)
        return bad("level_out_of_range", "z (level: 2^z texels per pixel) must be in [" +
                                             std::to_string(core::noise::kMinLevel) + ", " +
                                             std::to_string(core::noise::kMaxLevel) + "], not " +
                                             std::to_string(*v));
    out = static_cast<int>(*v);
    return std::nullopt;
}

// The plane is [-2^62, 2^62] texels (render/NOISE_SPEC.md): at level k >= 0 that is 2^(62-k)
// pixels; finer levels sample the same texels more densely and keep the 2^62-pixel bound.
std::optional<ApiError> check_window(std::int64_t x0, std::int64_t y0, std::int64_t w,
                                     std::int64_t h, int level) {
    const std::int64_t bound = (std::int64_t{1} << 62) >> (level > 0 ? level : 0);
    auto inside = [&](std::int64_t v, std::int64_t n) { return v >= -bound && v <= bound - n; };
    if (!inside(x0, w) || !inside(y0, h))
        return bad("coordinate_out_of_range",
                   "window outside the plane: at level " + std::to_string(level) +
                       " pixel coordinates must stay within +-" + std::to_string(bound));
    return std::nullopt;
}

// What every tile URL takes (a TileJSON too, but for quality: it writes PNG templates).
std::optional<ApiError> tile_fields(const Query& q, bool maps, bool tilejson, TileRequest& out) {
    const NoiseRoute route = maps ? kTileRoute : kMixTileRoute;
    if (auto e = tilejson ? check_fields(q, {"size"}, route)
                          : check_fields(q, {"size", "quality"}, route))
        return e;
    if (auto e = quality_of(q, out.format, out.quality)) return e;
    if (auto e = read_noise_fields(q, route, out.noise)) return e;
    if (const std::string* s = field(q, "size")) {
        auto v = parse_i64(*s);
        if (!v || (*v != 256 && *v != 512))
            return bad("invalid_parameter", "size must be 256 or 512, not '" + s->substr(0, 40) +
                                                "'" + canonical_hint(*s));
        out.size = static_cast<int>(*v);
    }
    return std::nullopt;
}

std::optional<ApiError> tile_common(std::string_view id, std::string_view x, std::string_view y,
                                    std::string_view ext, const Query& q, bool maps,
                                    TileRequest& out) {
    if (auto e = check_image_id(id)) return e;
    out.id = std::string(id);
    if (auto e = format_of(ext, out.format)) return e;
    if (auto e = tile_fields(q, maps, false, out)) return e;
    if (out.noise.map.encoding && out.format != ImageFormat::png)
        return bad("invalid_parameter", "elevation tiles (encoding=) are 8-bit RGB PNG: ask for "
                                        ".png, not ." +
                                            std::string(ext));
    // {y}@2x: the same square of the plane at twice the pixels, one level finer.
    constexpr std::string_view kRetina = "@2x";
    if (y.size() > kRetina.size() && y.substr(y.size() - kRetina.size()) == kRetina) {
        y.remove_suffix(kRetina.size());
        if (out.level - 1 < core::noise::kMinLevel)
            return bad("level_out_of_range",
                       "an @2x tile needs a level above " + std::to_string(core::noise::kMinLevel));
        out.level -= 1;
        out.size *= 2;
    }
    auto tx = parse_i64(x), ty = parse_i64(y);
    if (!tx || !ty)
        return bad("coordinate_out_of_range", "tile indices must be signed 64-bit integers, not '" +
                                                  std::string(x.substr(0, 40)) + "', '" +
                                                  std::string(y.substr(0, 40)) + "'" +
                                                  canonical_hint(parse_i64(x) ? y : x));
    // x * size must not overflow before the plane check sees it.
    const std::int64_t limit = INT64_MAX / out.size - 1;
    if (*tx > limit || *tx < -limit || *ty > limit || *ty < -limit)
        return bad("coordinate_out_of_range", "tile index too large for the plane");
    out.x = *tx;
    out.y = *ty;
    return check_window(out.x0(), out.y0(), out.size, out.size, out.level);
}

} // namespace

std::string exact_text(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

std::optional<ImageFormat> parse_image_format(std::string_view ext) {
    if (ext == "png") return ImageFormat::png;
    if (ext == "png16") return ImageFormat::png16;
    if (ext == "exr") return ImageFormat::exr;
    if (ext == "webp") return ImageFormat::webp;
    if (ext == "avif") return ImageFormat::avif;
    return std::nullopt;
}

namespace {

// Whether an Accept header lists `type` with a q above 0 (RFC 9110 section 12.5.1; wildcards
// are not a request for a modern format: browsers send */* with everything).
bool accepts(std::string_view accept, std::string_view type) {
    auto trim = [](std::string_view v) {
        while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
        while (!v.empty() && (v.back() == ' ' || v.back() == '\t')) v.remove_suffix(1);
        return v;
    };
    auto same = [](std::string_view a, std::string_view b) { // media types ignore case
        return a.size() == b.size() &&
               std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
                   return std::tolower(static_cast<unsigned char>(x)) ==
                          std::tolower(static_cast<unsigned char>(y));
               });
    };
    std::size_t at = 0;
    while (at <= accept.size()) {
        const std::size_t comma = std::min(accept.find(',', at), accept.size());
        std::string_view item = accept.substr(at, comma - at);
        at = comma + 1;
        std::size_t semi = std::min(item.find(';'), item.size());
        if (!same(trim(item.substr(0, semi)), type)) continue;
        // Its parameters: q=0 refuses it; one we cannot read is not an acceptance.
        bool refused = false;
        while (semi < item.size()) {
            const std::size_t next = std::min(item.find(';', semi + 1), item.size());
            const std::string_view param = trim(item.substr(semi + 1, next - semi - 1));
            if (param.size() > 2 && (param[0] == 'q' || param[0] == 'Q') && param[1] == '=') {
                const auto q = parse_finite(trim(param.substr(2)));
                refused = !q || *q <= 0.0;
            }
            semi = next;
        }
        return !refused;
    }
    return false;
}

} // namespace

ImageFormat negotiate_format(std::string_view accept) {
    if (accepts(accept, "image/avif")) return ImageFormat::avif;
    if (accepts(accept, "image/webp")) return ImageFormat::webp;
    return ImageFormat::png;
}

const char* content_type(ImageFormat f) {
    switch (f) {
    case ImageFormat::exr:
        return "image/x-exr";
    case ImageFormat::webp:
        return "image/webp";
    case ImageFormat::avif:
        return "image/avif";
    case ImageFormat::png:
    case ImageFormat::png16:
        break;
    }
    return "image/png";
}

const char* extension(ImageFormat f) {
    switch (f) {
    case ImageFormat::png:
        return "png";
    case ImageFormat::png16:
        return "png16";
    case ImageFormat::exr:
        return "exr";
    case ImageFormat::webp:
        return "webp";
    case ImageFormat::avif:
        return "avif";
    }
    return "";
}

bool is_texton_id(std::string_view s) {
    if (s.size() != 64) return false;
    for (char c : s)
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
    return true;
}

namespace {
// Texton, mix and splat ids are all sha256 hex; the message names the kind asked for.
std::optional<ApiError> check_id(const char* kind, std::string_view s) {
    if (is_texton_id(s)) return std::nullopt;
    std::string shown(s.substr(0, 80));
    for (char& c : shown)
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) c = '?';
    return bad("invalid_id", std::string(kind) +
                                 " ids are 64 lowercase hex digits (sha256), not '" + shown +
                                 (s.size() > 80 ? "...'" : "'"));
}
} // namespace

std::optional<ApiError> check_texton_id(std::string_view s) {
    return check_id("texton", s);
}

// The image routes serve textons, mixes and splats alike.
std::optional<ApiError> check_image_id(std::string_view s) {
    return check_id("texton, mix and splat", s);
}

bool canonical_number(std::string_view s, bool fraction) {
    std::size_t i = 0;
    if (i < s.size() && s[i] == '-') ++i;
    const std::size_t int_start = i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
    const std::size_t int_digits = i - int_start;
    if (int_digits == 0 || (int_digits > 1 && s[int_start] == '0')) return false;
    if (i < s.size() && fraction && s[i] == '.') {
        const std::size_t frac_start = ++i;
        while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
        if (i == frac_start || s[i - 1] == '0') return false;
    }
    if (i != s.size()) return false;
    // "-0" and "-0.0..." are zero's second spelling.
    return !(s[0] == '-' && s.find_first_not_of("-0.") == std::string_view::npos);
}

std::string query_text(double v) {
    if (v == 0) return "0";
    // A whole number in its digits, however large (1e21 as 1000000000000000000000: a ".0" is no
    // spelling of it).
    if (std::isfinite(v) && v == std::trunc(v)) {
        char buf[400];
        std::snprintf(buf, sizeof buf, "%.0f", v);
        return buf;
    }
    // The fewest decimals that read back as v, written without an exponent.
    char buf[400];
    for (int decimals = 1; decimals <= 340; ++decimals) {
        std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
        if (std::strtod(buf, nullptr) == v) break;
    }
    return buf;
}

std::string canonical_hint(std::string_view s) {
    std::string trimmed(s.substr(0, 64));
    trimmed.erase(0, trimmed.find_first_not_of(" \t"));
    trimmed.erase(trimmed.find_last_not_of(" \t") + 1);
    char* end = nullptr;
    const double v = trimmed.empty() ? NAN : std::strtod(trimmed.c_str(), &end);
    if (trimmed.empty() || end != trimmed.c_str() + trimmed.size() || !std::isfinite(v)) return "";
    const std::string canonical = query_text(v);
    if (canonical == s || canonical.size() > 40) return "";
    return " (one spelling per value: write " + canonical + ")";
}

std::optional<std::int64_t> parse_i64(std::string_view s) {
    if (!canonical_number(s, false)) return std::nullopt;
    std::int64_t v = 0;
    auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
    return v;
}

std::optional<std::uint64_t> parse_u64(std::string_view s) {
    if (s.empty() || s[0] == '-' || !canonical_number(s, false)) return std::nullopt;
    std::uint64_t v = 0;
    auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
    return v;
}

std::optional<double> parse_decimal(std::string_view s) {
    if (s.size() > 64 || !canonical_number(s, true)) return std::nullopt;
    const auto v = parse_finite(s);
    // 30.00000000000000001 is 30: one value, one spelling.
    if (!v || query_text(*v) != s) return std::nullopt;
    return v;
}

std::optional<double> parse_finite(std::string_view s) {
    if (s.empty() || s.size() > 64) return std::nullopt;
    const std::string copy(s);
    char* end = nullptr;
    const double v = std::strtod(copy.c_str(), &end);
    if (end != copy.c_str() + copy.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

std::optional<ApiError> parse_tile(std::string_view id, std::string_view z, std::string_view x,
                                   std::string_view y, std::string_view ext, const Query& q,
                                   TileRequest& out, bool maps) {
    if (auto e = check_image_id(id)) return e;
    if (auto e = level_of(z, out.level)) return e;
    return tile_common(id, x, y, ext, q, maps, out);
}

std::optional<ApiError> parse_map_tile(std::string_view id, std::string_view z, std::string_view x,
                                       std::string_view y, std::string_view ext, const Query& q,
                                       TileRequest& out, bool maps) {
    if (auto e = check_image_id(id)) return e;
    auto zoom = parse_i64(z);
    if (!zoom || *zoom < 0 || *zoom > kMapMaxZoom)
        return bad("level_out_of_range",
                   "map zoom must be an integer in [0, " + std::to_string(kMapMaxZoom) + "]");
    out.level = kMapMaxLevel - static_cast<int>(*zoom);
    return tile_common(id, x, y, ext, q, maps, out);
}

std::optional<ApiError> parse_region(std::string_view id, std::string_view ext, const Query& q,
                                     const Limits& limits, RegionRequest& out, bool maps) {
    const NoiseRoute route = maps ? kRegionRoute : kMixRegionRoute;
    if (auto e = check_image_id(id)) return e;
    out.id = std::string(id);
    if (auto e = format_of(ext, out.format)) return e;
    if (auto e = check_fields(q, {"x", "y", "w", "h", "z", "quality"}, route)) return e;
    if (auto e = quality_of(q, out.format, out.quality)) return e;
    if (auto e = read_noise_fields(q, route, out.noise)) return e;
    std::int64_t w = out.width, h = out.height;
    if (auto e = int_field(q, "w", 1, 16384, w)) return e;
    if (auto e = int_field(q, "h", 1, 16384, h)) return e;
    if (w * h > limits.max_region_pixels)
        return bad("region_too_large", "region of " + std::to_string(w) + "x" + std::to_string(h) +
                                           " pixels is over the limit of " +
                                           std::to_string(limits.max_region_pixels) + " pixels");
    if (out.format == ImageFormat::webp && (w > kMaxWebpSide || h > kMaxWebpSide))
        return bad("region_too_large",
                   "a WebP image is at most " + std::to_string(kMaxWebpSide) + " pixels a side");
    out.width = static_cast<int>(w);
    out.height = static_cast<int>(h);
    if (const std::string* s = field(q, "z"))
        if (auto e = level_of(*s, out.level)) return e;
    for (auto [name, dst] : {std::pair{"x", &out.x}, std::pair{"y", &out.y}}) {
        if (const std::string* s = field(q, name)) {
            auto v = parse_i64(*s);
            if (!v)
                return bad("coordinate_out_of_range",
                           std::string(name) + " must be a signed 64-bit integer, not '" +
                               s->substr(0, 40) + "'");
            *dst = *v;
        }
    }
    return check_window(out.x, out.y, out.width, out.height, out.level);
}

std::optional<ApiError> parse_tileable(std::string_view id, std::string_view ext, const Query& q,
                                       const Limits& limits, TileableRequest& out) {
    if (auto e = check_texton_id(id)) return e;
    out.id = std::string(id);
    if (auto e = format_of(ext, out.format)) return e;
    if (auto e = check_fields(q, {"w", "h", "quality"}, kTileableRoute)) return e;
    if (auto e = quality_of(q, out.format, out.quality)) return e;
    if (auto e = read_noise_fields(q, kTileableRoute, out.noise)) return e;
    std::int64_t w = out.width, h = out.height;
    if (auto e = int_field(q, "w", 8, limits.max_tileable_side, w)) return e;
    if (auto e = int_field(q, "h", 8, limits.max_tileable_side, h)) return e;
    // Held to a region's pixels: the memory bound counts one largest region a render slot (a
    // 4096 x 4096 AVIF took 1.5 times that).
    if (w * h > limits.max_region_pixels)
        return bad("region_too_large", "a tileable texture has at most " +
                                           std::to_string(limits.max_region_pixels) +
                                           " pixels (the server's --max-region-pixels), not " +
                                           std::to_string(w) + " x " + std::to_string(h));
    out.width = static_cast<int>(w);
    out.height = static_cast<int>(h);
    return std::nullopt;
}

std::optional<ApiError> parse_list(const Query& q, ListRequest& out) {
    if (auto e = check_fields(q, {"limit", "after"})) return e;
    std::int64_t limit = out.limit;
    if (auto e = int_field(q, "limit", 1, 1000, limit)) return e;
    out.limit = static_cast<int>(limit);
    if (const std::string* s = field(q, "after")) {
        if (auto e = check_texton_id(*s)) return e;
        out.after = *s;
    }
    return std::nullopt;
}

std::optional<ApiError> parse_tilejson(std::string_view id, const Query& q, TileRequest& out,
                                       bool maps) {
    if (auto e = check_image_id(id)) return e;
    out.id = std::string(id);
    return tile_fields(q, maps, true, out);
}

std::optional<ApiError> parse_spectrum(std::string_view id, const Query& q, NoiseParams& out) {
    if (auto e = check_image_id(id)) return e;
    if (auto e = check_fields(q, {}, kReportRoute)) return e;
    return read_noise_fields(q, kReportRoute, out);
}

std::optional<ApiError> parse_mix(const Query& q, bool has_mask, MixRequest& out) {
    if (has_mask) {
        if (auto e = check_fields(q, {"u", "v", "levels", "x0", "y0", "scale"})) return e;
        out.field.kind = core::MixField::Kind::mask;
    } else if (auto e = check_fields(q, {"u", "v", "levels", "x0", "y0", "dx", "dy", "width"})) {
        if (field(q, "scale"))
            return bad("invalid_parameter", "scale places a mask: send the mask image as the body");
        return e;
    }
    const std::string* u = field(q, "u");
    const std::string* v = field(q, "v");
    if (!u || !v) return bad("invalid_parameter", "u and v (two texton ids) are required");
    if (auto e = check_texton_id(*u)) return e;
    if (auto e = check_texton_id(*v)) return e;
    out.u = *u;
    out.v = *v;
    std::int64_t levels = out.levels;
    if (auto e = int_field(q, "levels", 2, core::kMaxMixLevels, levels)) return e;
    out.levels = static_cast<int>(levels);
    for (auto [name, dst] : {std::pair<const char*, double*>{"x0", &out.field.x0},
                             {"y0", &out.field.y0},
                             {"dx", &out.field.dx},
                             {"dy", &out.field.dy},
                             {"width", &out.field.width},
                             {"scale", &out.field.scale}})
        if (auto e = decimal_field(q, name, *dst)) return e;
    if (out.field.kind == core::MixField::Kind::mask) return std::nullopt; // mask checked later
    if (auto err = out.field.validate()) return bad("invalid_parameter", err->message);
    return std::nullopt;
}

std::optional<ApiError> check_mix_id(std::string_view s) {
    return check_id("mix", s);
}

namespace {

// A band [lo, hi] of the rules: two numbers, null for no bound.
std::optional<ApiError> band_of(const nlohmann::json& j, const char* name, core::SplatBand& out) {
    if (!j.is_array() || j.size() != 2)
        return bad("invalid_parameter",
                   std::string("rules: '") + name + "' is [lo, hi] (numbers, null for no bound)");
    for (std::size_t i = 0; i < 2; ++i) {
        if (j[i].is_null()) continue;
        if (!j[i].is_number())
            return bad("invalid_parameter",
                       std::string("rules: '") + name + "' bounds are numbers or null");
        (i == 0 ? out.lo : out.hi) = j[i].get<double>();
    }
    if (!(out.lo <= out.hi))
        return bad("invalid_parameter", std::string("rules: '") + name + "' needs lo <= hi");
    return std::nullopt;
}

std::optional<ApiError> rules_of(const std::string& text, int layers, SplatRequest& out) {
    // A few bands: built only once bounded (api/json_body.h).
    if (text.size() > 16384) return bad("invalid_parameter", "rules are at most 16 kB of JSON");
    if (auto e = check_json_bounds(text, 4, 512))
        return bad("invalid_parameter", "rules: " + e->message);
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object())
        return bad("invalid_parameter", "rules must be a JSON object");
    core::SplatRules& r = out.weights.rules;
    for (const auto& [key, value] : j.items()) {
        if (key == "height") {
            if (!value.is_string())
                return bad("invalid_parameter", "rules: 'height' is the height texton's id");
            if (auto e = check_texton_id(value.get<std::string>())) return e;
            out.height = value.get<std::string>();
        } else if (key == "strength" || key == "height_soft" || key == "slope_soft") {
            if (!value.is_number())
                return bad("invalid_parameter", "rules: '" + key + "' is a number");
            (key == "strength"      ? r.strength
             : key == "height_soft" ? r.height_soft
                                    : r.slope_soft) = value.get<double>();
        } else if (key == "layers") {
            if (!value.is_array())
                return bad("invalid_parameter", "rules: 'layers' is an array, one per texton");
            for (const auto& l : value) {
                if (!l.is_object())
                    return bad("invalid_parameter",
                               "rules: each layer is an object with 'height' and/or 'slope'");
                core::SplatRule rule;
                for (const auto& [name, band] : l.items()) {
                    if (name != "height" && name != "slope")
                        return bad("invalid_parameter", "rules: a layer takes 'height' and "
                                                        "'slope', not '" +
                                                            name.substr(0, 40) + "'");
                    if (auto e = band_of(band, name == "height" ? "height" : "slope",
                                         name == "height" ? rule.height : rule.slope))
                        return e;
                }
                r.layers.push_back(rule);
            }
        } else {
            return bad("invalid_parameter",
                       "rules: unknown key '" + key.substr(0, 40) +
                           "' (height, strength, height_soft, slope_soft, layers)");
        }
    }
    if (out.height.empty())
        return bad("invalid_parameter", "rules: 'height' (the height texton's id) is required");
    if (static_cast<int>(r.layers.size()) != layers)
        return bad("invalid_parameter", "rules: 'layers' has " + std::to_string(r.layers.size()) +
                                            " entries for " + std::to_string(layers) + " textons");
    return std::nullopt;
}

} // namespace

std::optional<ApiError> parse_splat(const Query& q, int weight_images, SplatRequest& out) {
    const bool rules = field(q, "rules") != nullptr;
    if (rules && weight_images > 0)
        return bad("invalid_parameter",
                   "a splat's weights are either images ('weights', 'weights2') or 'rules', not "
                   "both");
    if (!rules && weight_images == 0)
        return bad("missing_weights",
                   "a splat needs its weights: a 'weights' image (RGBA = 4 layers; 'weights2' "
                   "for layers 5 to 8) or 'rules' on a height texton");
    if (auto e = rules ? check_fields(q, {"textons", "rules"})
                       : check_fields(q, {"textons", "scale", "x0", "y0"}))
        return e;
    const std::string* list = field(q, "textons");
    if (!list)
        return bad("invalid_parameter", "textons (2 to 8 comma-separated texton ids) is required");
    out.textons.clear();
    for (std::size_t at = 0; at <= list->size();) {
        const std::size_t comma = std::min(list->find(',', at), list->size());
        const std::string id = list->substr(at, comma - at);
        if (auto e = check_texton_id(id)) return e;
        if (out.textons.size() == core::kMaxSplatLayers)
            return bad("invalid_parameter", "a splat has at most 8 layers");
        out.textons.push_back(id);
        at = comma + 1;
    }
    const int layers = static_cast<int>(out.textons.size());
    if (layers < core::kMinSplatLayers)
        return bad("invalid_parameter", "a splat has at least 2 layers (textons=ID,ID)");
    if (rules) {
        out.weights.kind = core::SplatWeights::Kind::rules;
        if (auto e = rules_of(*field(q, "rules"), layers, out)) return e;
        if (auto err = out.weights.validate(layers)) return bad("invalid_parameter", err->message);
        return std::nullopt;
    }
    out.weights.kind = core::SplatWeights::Kind::image;
    for (auto [name, dst] : {std::pair<const char*, double*>{"x0", &out.weights.image.x0},
                             {"y0", &out.weights.image.y0},
                             {"scale", &out.weights.image.scale}})
        if (auto e = decimal_field(q, name, *dst)) return e;
    if (layers > 4 && weight_images < 2)
        return bad("invalid_parameter", "layers 5 to 8 take their weights from 'weights2' (RGBA "
                                        "holds four)");
    if (layers <= 4 && weight_images == 2)
        return bad("invalid_parameter", "'weights2' holds layers 5 to 8; " +
                                            std::to_string(layers) +
                                            " layers take theirs from 'weights' alone");
    return std::nullopt; // the placement is checked with the pixels
}

std::optional<ApiError> check_splat_id(std::string_view s) {
    return check_id("splat", s);
}

std::optional<ApiError> parse_surface(std::string_view id, const Query& q, bool mesh,
                                      SurfaceParams& out) {
    if (auto e = check_texton_id(id)) return e;
    const NoiseRoute route = mesh ? kMeshRoute : kSurfaceRoute;
    if (mesh) {
        if (auto e = check_fields(q, {"scale", "width", "height", "fov", "eye", "target"}, route))
            return e;
        out.scale = 0; // automatic: the bounding box's diagonal spans 512 texels
    } else if (auto e = check_fields(q, {"scale"}, route)) {
        return e;
    }
    NoiseParams noise;
    noise.mni = out.mni; // a surface's own default density
    if (auto e = read_noise_fields(q, route, noise)) return e;
    out.seed = noise.seed;
    out.mni = noise.mni;
    out.exemplar_marginals = noise.exemplar_marginals;
    out.map = noise.map;
    out.light = field(q, "light") != nullptr;
    if (out.map.name == core::kNormalMap || (!mesh && out.map.name == core::kLitMap))
        return bad("invalid_parameter",
                   mesh ? "map=normal is an image of the plane; mesh.png lights a set's mesh "
                          "through its height's relief (map=lit, the default with a height)"
                        : "surface colours come from a map of the set: albedo, height, roughness, "
                          "ao or metallic, not " +
                              out.map.name);
    auto number = [&](const char* name, double lo, double hi,
                      double& dst) -> std::optional<ApiError> {
        if (const std::string* s = field(q, name)) {
            auto v = parse_decimal(*s);
            if (!v || *v < lo || *v > hi)
                return bad("invalid_parameter", std::string(name) + " must be a number in [" +
                                                    number_text(lo) + ", " + number_text(hi) + "]");
            dst = *v;
        }
        return std::nullopt;
    };
    if (auto e = number("scale", mesh ? 0 : 1e-9, 1e9, out.scale)) return e;
    if (!mesh) return std::nullopt;
    if (auto e = number("fov", 5, 150, out.fov)) return e;
    std::int64_t w = out.width, h = out.height;
    if (auto e = int_field(q, "width", 16, 2048, w)) return e;
    if (auto e = int_field(q, "height", 16, 2048, h)) return e;
    out.width = static_cast<int>(w);
    out.height = static_cast<int>(h);
    const std::string* eye = field(q, "eye");
    const std::string* target = field(q, "target");
    if (!eye != !target) return bad("invalid_parameter", "eye and target go together");
    if (eye) {
        for (auto [text, dst] :
             {std::pair<const std::string*, double*>{eye, out.eye}, {target, out.target}}) {
            std::size_t start = 0;
            for (int k = 0; k < 3; ++k) {
                const std::size_t comma = text->find(',', start);
                if ((k < 2) == (comma == std::string::npos))
                    return bad("invalid_parameter", "eye and target are x,y,z");
                auto v = parse_decimal(text->substr(start, comma - start));
                if (!v) return bad("invalid_parameter", "eye and target are x,y,z numbers");
                dst[k] = *v;
                start = comma + 1;
            }
        }
        out.camera = true;
    }
    return std::nullopt;
}

std::optional<ApiError> parse_kit(std::string_view id, const Query& q, NoiseParams& out) {
    if (auto e = check_texton_id(id)) return e;
    if (auto e = check_fields(q, {}, kKitRoute)) return e;
    return read_noise_fields(q, kKitRoute, out);
}

std::optional<ApiError> parse_analysis(const Query& q, core::AnalysisParams& out) {
    if (auto e = check_fields(q, {"size", "order", "iterations", "seed", "periodic"})) return e;
    std::int64_t size = out.size, order = out.order, iterations = out.iterations;
    if (auto e = int_field(q, "size", 8, 256, size)) return e;
    if (auto e = int_field(q, "order", 0, 3, order)) return e;
    if (order == 2) return bad("invalid_parameter", "order must be 0, 1 or 3");
    if (auto e = int_field(q, "iterations", 1, 1000, iterations)) return e;
    out.size = static_cast<int>(size);
    out.order = static_cast<int>(order);
    out.iterations = static_cast<int>(iterations);
    if (const std::string* s = field(q, "seed")) {
        auto v = parse_u64(*s);
        if (!v) return bad("invalid_parameter", "seed must be an unsigned 64-bit integer");
        out.seed = *v;
    }
    if (const std::string* s = field(q, "periodic")) {
        if (*s == "true" || *s == "1")
            out.periodic = true;
        else if (*s == "false" || *s == "0")
            out.periodic = false;
        else
            return bad("invalid_parameter", "periodic must be true or false (or 1 or 0)");
    }
    return std::nullopt;
}

} // namespace textond::api
