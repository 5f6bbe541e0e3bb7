#include "server/http/errors.h"

#include <spdlog/spdlog.h>

#include <iterator>

namespace textond::http {

namespace {
// Kept as a constant array so the function that lends it out as a vector stays short.
constexpr ErrorStatus kTable[] = {
    // The request as sent (api/requests.cpp and the routes).
    {"invalid_parameter", 400},
    {"unknown_parameter", 400},
    {"unknown_preset", 400},
    {"invalid_id", 400},
    {"invalid_format", 400},
    {"coordinate_out_of_range", 400},
    {"level_out_of_range", 400},
    {"region_too_large", 400},
    {"empty_body", 400},
    {"missing_exemplar", 400},
    {"missing_weights", 400},
    {"map_size_mismatch", 400},
    {"bad_request", 400},
    {"bad_framing", 400},
    {"non_canonical_url", 400},
    {"unsupported_transfer_encoding", 400},
    {"invalid_body", 400},
    {"unauthorized", 401},
    // Signed URLs and presets (server/app/url_signing.h).
    {"signature_missing", 403},
    {"signature_invalid", 403},
    {"signature_expired", 403},
    {"signing_unavailable", 403},
    {"preset_required", 403},
    {"not_found", 404},
    // The connection (server/http/connection.cpp, request_body.cpp).
    {"header_timeout", 408},
    {"body_timeout", 408},
    {"client_gone", 408},
    {"length_required", 411},
    {"precondition_failed", 412},
    {"payload_too_large", 413},
    {"work_too_large", 413},
    {"image_too_large", 413},
    {"too_large", 413},
    {"uri_too_long", 414},
    {"unsupported_media_type", 415},
    {"range_not_satisfiable", 416},
    // The content.
    {"invalid_image", 422},
    {"invalid_mask", 422},
    {"invalid_weights", 422},
    {"invalid_mesh", 422},
    {"exemplar_too_small", 422},
    {"unprocessable", 422},
    // The server.
    {"overloaded", 429},
    {"rate_limited", 429},
    {"header_too_large", 431},
    {"too_many_headers", 431},
    {"internal", 500},
    {"storage_error", 500},
    {"deadline_exceeded", 503},
    {"shutting_down", 503},
    {"store_unavailable", 503},
    {"insufficient_storage", 507},
};
} // namespace

const std::vector<ErrorStatus>& error_table() {
    static const std::vector<ErrorStatus> table(std::begin(kTable), std::end(kTable));
    return table;
}

int http_status(std::string_view code) {
    for (const ErrorStatus& e : error_table())
        if (e.code == code) return e.status;
    spdlog::error("error code '{}' is not in server/http/errors.cpp; answered 500", code);
    return 500;
}

} // namespace textond::http
