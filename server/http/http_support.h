#pragma once
// What every route shares: the per-request context (id, start time, route template), the one
// JSON error body, the mapping from library errors to HTTP, and entity-tag matching.
#include "api/requests.h"
#include "core/result.h"
#include "server/http/imports.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <string>
#include <string_view>
#include <vector>

namespace textond::http {

// cpp-httplib runs pre-routing, the handler, the error handler and the logger of one request on
// one thread, so the context of the request being served lives in a thread_local.
struct RequestContext {
    std::string id;
    std::string route = "unmatched"; // route template for metrics, e.g. /v1/textons/{id}
    std::chrono::steady_clock::time_point start;
    double handler_ms = 0; // until the response is ready, before it is written
    bool active = false;
    // The request being served. cpp-httplib 0.11 applies a Range header to every routed answer,
    // errors included (a 404's JSON sliced into multipart/byteranges); an error clears its
    // ranges. The library's Request is its own local, not const, so the cast is well defined.
    httplib::Request* request = nullptr;
};
RequestContext& current_request();
// Cache-Control of what a DELETE takes away and that is not content-addressed noise (the
// exemplar, the texton's files, the engine kit): revalidated on every use, so no cache, the
// edge's included, serves one after its texton is deleted (a minute's max-age did). Noise images
// are immutable and stay in caches until they expire (deploy/README.md "Run at scale").
inline constexpr const char* kDeletableFor = "no-cache";
// cpp-httplib 0.11 applies a Range to a body without fitting it (bytes=0-99999999 of a 100 kB
// body read past its end from a content provider, and named a false Content-Range otherwise):
// the request's ranges are made to fit `size` here, suffix and open ranges resolved, and a Range
// that selects nothing is dropped, the whole answered (RFC 9110 lets a server ignore Range).
void fit_ranges(std::size_t size);
// A new request id: a per-process random prefix and a counter.
std::string fresh_request_id();
// Starts a context: the client's X-Request-Id when it is sane, else a fresh one.
void begin_request(const httplib::Request& req);
void set_route(const char* route_template);

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

// RFC 9110 If-None-Match: a list of strong or weak tags, or "*".
bool etag_matches(std::string_view if_none_match, std::string_view etag);

// Writes need `Authorization: Bearer <api_key>` when an API key is set (compared in constant
// time); 401 with WWW-Authenticate sent when not.
bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res);

// "a, b,c" -> {"a", "b", "c"}: spaces trimmed, empty items dropped (--formats, --cors-origin).
std::vector<std::string> split_list(std::string_view s);

// The headers every answer carries (the page framed or sniffed; deploy/README.md "Hostile
// clients"), the connection's own canned answers included.
const std::vector<std::pair<const char*, const char*>>& security_headers();

} // namespace textond::http
