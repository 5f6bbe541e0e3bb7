#pragma once
// What answers share: the one JSON error body and the mapping from library errors to it, JSON
// bodies, the headers every answer carries, and the cache validators of deletable resources.
#include "api/requests.h"
#include "core/result.h"
#include "server/http/imports.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace textond::http {

// Cache-Control of what a DELETE takes away and that is not content-addressed noise (the
// exemplar, the texton's files, the engine kit): revalidated on every use, so no cache, the
// edge's included, serves one after its texton is deleted (a minute's max-age did). Noise images
// are immutable and stay in caches until they expire (deploy/README.md "Run at scale").
inline constexpr const char* kDeletableFor = "no-cache";
// {"error": {"code", "message"}, "request_id"} with the status, and `Cache-Control: no-store`.
// The error body with the status of e.code (server/http/errors.cpp), or `status` when given
// (cpp-httplib's own errors, code http_error).
void send_error(httplib::Response& res, const api::ApiError& e, int status = 0) noexcept;
// Bytes a client sent that do not decode (an exemplar, a mask, a mesh): too large (`too_large`,
// 413), a format not taken (unsupported_media_type, 415) or not what they claim (`invalid`,
// 422); anything else as to_api_error.
api::ApiError content_error(const Error& e, const char* invalid,
                            const char* too_large = "image_too_large");
void send_json(httplib::Response& res, int status, const nlohmann::json& body,
               const char* cache_control = "no-cache");

// The one mapping table from library errors to HTTP (style.md): invalid argument 400, too large
// 413, unsupported media 415, unprocessable 422, not found 404, no space 507, otherwise 500.
api::ApiError to_api_error(const Error& e, std::string code = {});

// Routes whose answer no query changes take none: `texton.png?x=1` would be a second URL, so a
// second cache entry at every edge, for one answer. 400 unknown_parameter sent when there is one;
// a signed URL's `sig` and `exp` pass (`textond sign` and POST /v1/sign sign any path).
bool takes_no_query(const httplib::Request& req, httplib::Response& res);

// RFC 9110 If-None-Match: a list of strong or weak tags, or "*".
bool etag_matches(std::string_view if_none_match, std::string_view etag);
// RFC 9110 If-Match (13.1.1) on a resource that exists: true when absent or "*", else when one
// tag of the list is `etag` by the strong comparison (a weak tag never matches; an empty `etag`,
// a resource without one, matches nothing). False: 412, and the method is not performed.
bool if_match_holds(std::string_view if_match, std::string_view etag);
// A DELETE's If-Match that names tags: a texton, mix or splat has none (content addressed, it
// never changes), so only "*" holds where it exists.
api::ApiError no_entity_tag(const char* what);

// The headers every answer carries (the page framed or sniffed; deploy/README.md "Hostile
// clients"), the connection's own canned answers included.
const std::vector<std::pair<const char*, const char*>>& security_headers();

} // namespace textond::http
