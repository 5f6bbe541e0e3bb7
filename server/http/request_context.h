#pragma once
// The request being served: its id, start time and route template (for logs and metrics), and
// the Range header fitted to the body it is answered with.
#include "server/http/imports.h"

#include <httplib.h>

#include <chrono>
#include <cstddef>
#include <string>

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
    httplib::Ranges if_range_ranges; // held back under If-Range until fit_ranges sees the ETag
};
RequestContext& current_request();

// cpp-httplib 0.11 applies a Range to a body without fitting it (bytes=0-99999999 of a 100 kB
// body read past its end from a content provider, and named a false Content-Range otherwise):
// the request's ranges are made to fit `size` here, suffix and open ranges resolved, and a Range
// that selects nothing is dropped, the whole answered (RFC 9110 lets a server ignore Range).
// Under If-Range (RFC 9110 13.1.5) a Range holds only while its validator is `res`'s strong ETag,
// set before this (ETags change with the build); otherwise, or for a date (no answer has
// Last-Modified), the whole answer, never a part of a changed one.
void fit_ranges(const httplib::Response& res, std::size_t size);
// A new request id: a per-process random prefix and a counter.
std::string fresh_request_id();
// Starts a context: the client's X-Request-Id when it is sane, else a fresh one.
void begin_request(const httplib::Request& req);
void set_route(const char* route_template);

} // namespace textond::http
