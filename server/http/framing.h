#pragma once
// Message framing (RFC 9112 section 6): one request's bytes and no more are read as that
// request. cpp-httplib 0.11 parses any body on any method and leaves unread bytes on the wire, so
// a GET whose Content-Length hides a second request got two answers, and behind a proxy that
// pools connections the second would go to another client. What the service and the
// framing fuzzer (tests/fuzz/request_fuzzer.cpp) share:
#include "api/requests.h"
#include "server/http/imports.h"

#include <httplib.h>

#include <cstddef>
#include <optional>

namespace textond::http {

// The header checks the library does not make, run before any body byte is read: one decimal
// Content-Length (no sign, list, hex or duplicate: such a request smuggles a second one past a
// proxy that reads the other value), not both Content-Length and Transfer-Encoding, and only
// "chunked" as a transfer encoding, on POST alone; at most `max_headers` header lines.
std::optional<api::ApiError> check_framing(const httplib::Request& req, std::size_t max_headers);

// Pre-routing, for the connection being served: the head has been read, so bytes now count
// against the body. A request refused here (framing, or a Content-Length over `max_body_bytes`)
// closes its connection after the answer, since its body is still on the wire; an accepted one
// tells the connection which body to expect, and the connection closes unless the route reads
// all of it.
std::optional<api::ApiError> frame_request(const httplib::Request& req, std::size_t max_headers,
                                           std::size_t max_body_bytes);

// Post-routing: says `Connection: close` when the connection closes after this answer, so that a
// pooling proxy does not send its next request down a socket about to close.
void announce_close(httplib::Response& res);

// An error the library raised itself (status `status`): before pre-routing saw the request (a
// head it could not parse, a URI over its limit) nobody checked its framing or read its body,
// and after a 400 the bytes that follow are not known to be a request, so the connection closes.
void close_after_library_error(int status);

} // namespace textond::http
