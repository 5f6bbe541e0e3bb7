#pragma once
// The v1 requests as plain structs, parsed and validated from path segments and query fields
// (../shared/design/style.md: OSRM's *_parameters). No HTTP here: server/ hands in strings and maps
// ApiError to a response. Every rule below is also written in api/openapi.yaml.
#include "core/elevation_encoding.h"
#include "core/material_set.h"
#include "core/splat_blend.h"
#include "core/texton_analysis.h"
#include "core/texture_mix.h"

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace textond::api {

// What a client did wrong (or what went wrong for it): a stable machine-readable code and a
// sentence for people. server/http/errors.cpp alone maps a code to an HTTP status; one JSON body
// everywhere (send_error in server/http).
struct ApiError {
    std::string code = "internal";
    std::string message;
};

using Query = std::multimap<std::string, std::string>; // httplib::Params has this type

enum class ImageFormat { png, png16, exr, webp, avif };
// "png" | "png16" | "exr" | "webp" | "avif"
std::optional<ImageFormat> parse_image_format(std::string_view ext);
// What an extension-less tile URL is answered with: AVIF, then WebP when the Accept header
// names them (with a q above 0), else PNG.
ImageFormat negotiate_format(std::string_view accept);
const char* content_type(ImageFormat f);
const char* extension(ImageFormat f); // without the dot, as in URLs

// Texton ids are lowercase sha256 hex: nothing else can reach the store's file names.
bool is_texton_id(std::string_view s);
std::optional<ApiError> check_texton_id(std::string_view s);
// An id on the image routes, which textons, mixes and splats share (the same form, sha256 hex).
std::optional<ApiError> check_image_id(std::string_view s);

struct Limits {
    std::int64_t max_region_pixels = 8'388'608; // a 4K UHD frame (3840 x 2160) fits
    int max_tileable_side = 4096;
};

// Which view of a material set an image shows: one of its maps (core/material_set.h; "" = albedo,
// or the set's first map), "normal" (made from the height with `strength`, render/normal_map.h) or
// "lit" (the albedo lit through that normal map by a light from `azimuth`, `elevation`, degrees).
// encoding= of map=height tiles: metres for the height map's 0..1 (height_scale=) by default.
inline constexpr double kDefaultHeightScale = 100.0;
inline constexpr double kMaxHeightScale = 100000.0;

struct MapChoice {
    std::string name;
    double strength = core::kDefaultNormalStrength;
    double azimuth = core::kDefaultLightAzimuth;
    double elevation = core::kDefaultLightElevation;
    // map=height as elevation tiles (core/elevation_encoding.h): RGB PNG in metres.
    std::optional<core::ElevationEncoding> encoding;
    double height_scale = kDefaultHeightScale;
    bool uses_normals() const { return name == core::kNormalMap || name == core::kLitMap; }
};

// The noise parameters of the image endpoints; api/noise_fields.h reads and writes them, and
// says which endpoint takes which.
struct NoiseParams {
    std::uint64_t seed = 0;
    double mni = 30.0;
    // marginals=exemplar: each pixel mapped onto the exemplar's colour marginals (README
    // "Marginals"); the default, gaussian, is the noise as it is.
    bool exemplar_marginals = false;
    MapChoice map; // map=, strength=, light=, encoding=, height_scale=
};

// libwebp's largest side (WEBP_MAX_DIMENSION).
inline constexpr int kMaxWebpSide = 16383;

// quality= of lossy formats: 1..100; 0 is the format's default (WebP: lossless, AVIF: 80).
inline constexpr int kDefaultQuality = 0;

struct TileRequest {
    std::string id;
    int level = 0;             // z: 2^z texels per pixel, -4..24
    std::int64_t x = 0, y = 0; // tile indices, any int64 whose pixels stay on the plane
    int size = 256;            // 256 or 512; twice that for @2x (which is one level finer)
    ImageFormat format = ImageFormat::png;
    int quality = kDefaultQuality;
    NoiseParams noise;
    std::int64_t x0() const { return x * size; }
    std::int64_t y0() const { return y * size; }
};

struct RegionRequest {
    std::string id;
    int level = 0;
    std::int64_t x = 0, y = 0; // window origin in pixels of the level
    int width = 512, height = 512;
    ImageFormat format = ImageFormat::png;
    int quality = kDefaultQuality;
    NoiseParams noise;
};

struct TileableRequest {
    std::string id;
    int width = 512, height = 512;
    ImageFormat format = ImageFormat::png;
    int quality = kDefaultQuality;
    NoiseParams noise;
};

struct ListRequest {
    int limit = 50;    // 1..1000
    std::string after; // cursor: the last id of the previous page
};

// Path pieces arrive as the raw strings of the URL (already percent-decoded by the server).
// `maps`: whether the id's kind takes map= (app::ImageSource::has_maps: a texton does; a texture
// mix and a splat map, whose routes' fields are kMixTileRoute's in api/noise_fields.h, do not).
std::optional<ApiError> parse_tile(std::string_view id, std::string_view z, std::string_view x,
                                   std::string_view y, std::string_view ext, const Query& q,
                                   TileRequest& out, bool maps = true);
// The web-map flavour (TileJSON): client zoom Z, larger = more detail, level = kMapMaxLevel - Z.
inline constexpr int kMapMaxLevel = 24;
inline constexpr int kMapMaxZoom = 28; // level -4
std::optional<ApiError> parse_map_tile(std::string_view id, std::string_view z, std::string_view x,
                                       std::string_view y, std::string_view ext, const Query& q,
                                       TileRequest& out, bool maps = true);
std::optional<ApiError> parse_region(std::string_view id, std::string_view ext, const Query& q,
                                     const Limits& limits, RegionRequest& out, bool maps = true);
std::optional<ApiError> parse_tileable(std::string_view id, std::string_view ext, const Query& q,
                                       const Limits& limits, TileableRequest& out);
std::optional<ApiError> parse_list(const Query& q, ListRequest& out);
// TileJSON: the tile fields it will write into its templates (not quality: they are PNG).
std::optional<ApiError> parse_tilejson(std::string_view id, const Query& q, TileRequest& out,
                                       bool maps = true);
// POST /v1/mixes: two texton ids, the level count and the field. Without a body the field is a
// ramp (x0, y0, dx, dy, width); with one (a mask image, decoded by the caller) it is the mask's
// placement (x0, y0, scale).
struct MixRequest {
    std::string u, v;
    int levels = 21;
    core::MixField field;
};
std::optional<ApiError> parse_mix(const Query& q, bool has_mask, MixRequest& out);
std::optional<ApiError> check_mix_id(std::string_view s);

// POST /v1/splats: the form fields beside the weight images (decoded by the caller): `textons`,
// 2 to 8 comma-separated ids in layer order, and either the images' placement (scale, x0, y0;
// `weight_images` of them sent: `weights` for up to 4 layers, and `weights2` for 5 to 8) or
// `rules`, a JSON object of bands on a height texton:
//   {"height": ID, "strength": 4, "height_soft": 0.05, "slope_soft": 5,
//    "layers": [{"height": [lo, hi], "slope": [lo, hi]}, ...]}   (null: no bound).
struct SplatRequest {
    std::vector<std::string> textons;
    core::SplatWeights weights; // image: its placement only
    std::string height;         // rules: the height texton's id
};
std::optional<ApiError> parse_splat(const Query& q, int weight_images, SplatRequest& out);
std::optional<ApiError> check_splat_id(std::string_view s);

// POST /v1/textons/{id}/surface and /mesh.png: seed, mni (default 60), scale (texels per unit;
// 0 = automatic for meshes); meshes also width, height, fov and an optional eye and target.
struct SurfaceParams {
    std::uint64_t seed = 0;
    double mni = 60.0;
    double scale = 1.0;
    int width = 512, height = 512;
    double fov = 35;
    bool camera = false; // eye and target given
    double eye[3] = {0, 0, 0}, target[3] = {0, 0, 0};
    bool exemplar_marginals = false; // marginals=exemplar (NoiseParams)
    // A material set's view: colours of map.name (default albedo); mesh.png also takes "lit"
    // (its default for a set with a height: the height's relief bends the normals, strength=).
    MapChoice map;
    // mesh.png: light=AZIMUTH,ELEVATION (degrees; +y up, azimuth from +x towards +z), in
    // map.azimuth and map.elevation; the default light is (0.4, 0.8, 0.6).
    bool light = false;
};
std::optional<ApiError> parse_surface(std::string_view id, const Query& q, bool mesh,
                                      SurfaceParams& out);

// GET /v1/textons/{id}/kit.tar[?mni=M]
std::optional<ApiError> parse_kit(std::string_view id, const Query& q, NoiseParams& out);
// spectrum.png, quality.png and quality.json: seed and mni of the noise window.
std::optional<ApiError> parse_spectrum(std::string_view id, const Query& q, NoiseParams& out);
// Analysis parameters of POST /v1/textons (query or form fields): size, order, iterations, seed,
// periodic. Unknown fields are refused so that a typo never silently analyses with defaults.
std::optional<ApiError> parse_analysis(const Query& q, core::AnalysisParams& out);

// %.17g: two doubles that differ print differently (cache keys, ETags, URLs, files, metrics).
std::string exact_text(double v);

// Strict number parsing: the whole string, no overflow, no NaN.
// Numbers in URLs have one spelling each (caches key on the text, so "050", "+50" and "0x32"
// would be three URLs of one image): an optional '-', no leading zeros, no '+', spaces, hex or
// exponent, a fraction (where allowed) without trailing zeros, and no "-0".
bool canonical_number(std::string_view s, bool fraction);
// " (one spelling per value: write 16)" for a number spelled otherwise ("0x10", " 16"), else "".
std::string canonical_hint(std::string_view s);
// The canonical spelling of a number in a URL: "30", "1.1", "0.000001" (the fewest decimals
// that read back as v, no exponent). What the server writes into the URLs it hands out.
std::string query_text(double v);
// A query field's decimal number, canonical (above) and finite.
std::optional<double> parse_decimal(std::string_view s);
std::optional<std::int64_t> parse_i64(std::string_view s);
std::optional<std::uint64_t> parse_u64(std::string_view s);
std::optional<double> parse_finite(std::string_view s);

} // namespace textond::api
