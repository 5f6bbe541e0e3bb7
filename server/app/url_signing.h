#pragma once
// Signed image URLs and presets (--url-signing-key, --presets): so that nobody can make the
// server render endless parameter combinations, every image URL carries
//   sig = hex(HMAC-SHA256(key, canonical)),
//   canonical = signed path + "?" + the query's fields but sig, sorted by name then value,
//               as name=value (decoded, then '%', '&' and '=' escaped) joined by "&",
// and optionally exp (Unix seconds, signed like any field) after which it is refused. A tile's
// signed path is its layer, with {z}/{x}/{y} in place of the tile's numbers, so one signature
// serves a whole tile pyramid (TileJSON hands out signed templates); any other path is signed as
// it is. With presets, image URLs carry preset=NAME (plus sig and exp) and nothing else: the
// preset's fields are what the request asks for. No HTTP here: server/http/image_routes.cpp
// applies it.
#include "api/requests.h"
#include "core/result.h"

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace textond::app {

// A preset: its query fields and, optionally, the one image format its URLs must ask for.
struct Preset {
    api::Query fields;
    std::string format; // "" = any
};
using Presets = std::map<std::string, Preset>;

// {"NAME": {"format": "webp", "seed": 0, "quality": 80, ...}, ...}: names of letters, digits,
// '-', '_' and '.'; a format each; values strings or numbers, as their query fields would be
// written, checked as a tile request checks them.
Result<Presets> parse_presets(std::string_view json);

// A key an attacker holding one signed URL cannot search for offline.
inline constexpr std::size_t kMinSigningKey = 16;

// The path a signature covers (tile routes: the layer; others: the path itself).
std::string signed_path(std::string_view path);
std::string canonical_request(std::string_view path, const api::Query& query);
std::string url_signature(std::string_view key, std::string_view canonical);

// Checks sig and exp of a request to `path` with `query` at `now` (Unix seconds); nothing when
// the signature holds. 403 codes: signature_missing, signature_invalid, signature_expired.
std::optional<api::ApiError> check_signature(std::string_view key, std::string_view path,
                                             const api::Query& query, std::int64_t now);

// `url` (a path with its query, or an absolute URL) with exp (when expires > 0) and sig added.
Result<std::string> sign_url(std::string_view key, std::string_view url, std::int64_t expires);

// The fields a request with presets asks for: the preset's, plus the signature's own; 400
// preset_required, unknown_preset or invalid_parameter (another field, or another format).
std::optional<api::ApiError> apply_preset(const Presets& presets, const api::Query& query,
                                          std::string_view format, api::Query& out);

} // namespace textond::app
