#include "server/http/framing.h"

#include "api/safe_text.h"
#include "server/http/connection.h"
#include "server/http/request_context.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <string>

namespace textond::http {

std::optional<api::ApiError> check_framing(const httplib::Request& req, std::size_t max_headers) {
    auto bad = [](std::string m) { return api::ApiError{"bad_framing", std::move(m)}; };
    // cpp-httplib adds REMOTE_ADDR, REMOTE_PORT, LOCAL_ADDR and LOCAL_PORT to the client's lines.
    std::size_t lines = req.headers.size();
    for (const char* own : {"REMOTE_ADDR", "REMOTE_PORT", "LOCAL_ADDR", "LOCAL_PORT"})
        lines -= std::min<std::size_t>({1, lines, req.get_header_value_count(own)});
    if (lines > max_headers)
        return api::ApiError{"too_many_headers",
                             "more than " + std::to_string(max_headers) + " header lines"};
    const std::size_t lengths = req.get_header_value_count("Content-Length");
    const std::size_t encodings = req.get_header_value_count("Transfer-Encoding");
    if (lengths > 1) return bad("more than one Content-Length header");
    if (lengths == 1) {
        const std::string v = req.get_header_value("Content-Length");
        if (v.empty() || v.size() > 18 ||
            !std::all_of(v.begin(), v.end(), [](unsigned char c) { return std::isdigit(c); }))
            return bad("Content-Length must be one decimal number");
    }
    // No route but POST reads a body, so a body on GET, HEAD, OPTIONS or DELETE would stay on
    // the wire and be read as the next request (one client's hidden request answered to another
    // behind a proxy that pools connections).
    if (lengths == 1 && req.method != "POST" && req.get_header_value("Content-Length") != "0")
        return bad("a " + api::printable(req.method, 16) + " request carries no body");
    if (encodings > 1) return bad("more than one Transfer-Encoding header");
    if (encodings == 1) {
        std::string te = req.get_header_value("Transfer-Encoding");
        std::transform(te.begin(), te.end(), te.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (te != "chunked")
            return api::ApiError{"unsupported_transfer_encoding",
                                 "only Transfer-Encoding: chunked is supported"};
        if (lengths == 1) return bad("both Content-Length and Transfer-Encoding");
        if (req.method != "POST") return bad("a chunked body is only accepted on POST routes");
    }
    // cpp-httplib reads such a body until the client closes its side: ask for a length instead.
    if (lengths == 0 && encodings == 0 &&
        (req.method == "POST" || req.method == "PUT" || req.method == "PATCH"))
        return api::ApiError{"length_required",
                             "a " + req.method.substr(0, 8) +
                                 " needs Content-Length (0 for no body)" +
                                 (req.method == "POST" ? " or a chunked body" : "")};
    return std::nullopt;
}

std::optional<api::ApiError> frame_request(const httplib::Request& req, std::size_t max_headers,
                                           std::size_t max_body_bytes) {
    ConnectionStream* conn = current_connection();
    if (conn) conn->begin_body();
    auto refuse = [&](api::ApiError e) {
        if (conn) conn->close_after_response();
        return std::optional<api::ApiError>(std::move(e));
    };
    if (auto e = check_framing(req, max_headers)) return refuse(std::move(*e));
    const std::uint64_t length =
        req.has_header("Content-Length")
            ? std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10)
            : 0;
    // Over the limit by its own account: answered before a byte of it is read (the library would
    // read and discard it all first).
    if (length > max_body_bytes)
        return refuse({"payload_too_large", "request body is over the upload limit of " +
                                                std::to_string(max_body_bytes) + " bytes"});
    if (conn) conn->expect_body(length, req.has_header("Transfer-Encoding"));
    return std::nullopt;
}

void announce_close(httplib::Response& res) {
    const ConnectionStream* conn = current_connection();
    if (!conn || (!conn->must_close() && conn->body_complete())) return;
    res.headers.erase("Keep-Alive");
    res.headers.erase("Connection");
    res.set_header("Connection", "close");
}

void close_after_library_error(int status) {
    if (!current_request().active || status == 400)
        if (ConnectionStream* conn = current_connection()) conn->close_after_response();
}

} // namespace textond::http
