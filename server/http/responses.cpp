#include "server/http/responses.h"

#include "server/http/errors.h"
#include "server/http/request_context.h"

#include "api/safe_text.h"

namespace textond::http {

void send_error(httplib::Response& res, const api::ApiError& e, int status) noexcept {
    if (status == 0) status = http_status(e.code);
    // The error path must not fail in turn: messages echo client bytes (printable() makes them
    // valid UTF-8, capped), and should anything still throw, a fixed body goes out.
    try {
        RequestContext& ctx = current_request();
        if (!ctx.active) {
            begin_request(httplib::Request{});
            ctx.request = nullptr;
        }
        if (ctx.request) ctx.request->ranges.clear(); // an error is answered whole
        const nlohmann::json body = {
            {"error",
             {{"code", api::printable(e.code, 64)}, {"message", api::printable(e.message, 1024)}}},
            {"request_id", ctx.id}};
        res.status = status;
        res.set_header("Cache-Control", "no-store");
        // The shared store fails fast for a second after it is found down (server/store).
        if (status == 503 && !res.has_header("Retry-After")) res.set_header("Retry-After", "1");
        res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
                        "application/json");
    } catch (...) {
        res.status = status;
        res.body = R"({"error": {"code": "internal", "message": "error body unavailable"}})";
        res.set_header("Content-Type", "application/json");
    }
}

void send_json(httplib::Response& res, int status, const nlohmann::json& body,
               const char* cache_control) {
    res.status = status;
    // A JSON answer is always whole (cpp-httplib would slice it under a 200).
    if (httplib::Request* req = current_request().request) req->ranges.clear();
    if (cache_control) res.set_header("Cache-Control", cache_control);
    // replace: a string that came from a client and is not UTF-8 becomes U+FFFD, never a throw.
    res.set_content(body.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n",
                    "application/json");
}

bool takes_no_query(const httplib::Request& req, httplib::Response& res) {
    for (const auto& param : req.params) {
        if (param.first == "sig" || param.first == "exp") continue; // `textond sign` adds them
        send_error(res, {"unknown_parameter", "this route takes no query parameters, not '" +
                                                  api::printable(param.first, 40) + "'"});
        return false;
    }
    return true;
}

api::ApiError to_api_error(const Error& e, std::string code) {
    auto pick = [&](const char* fallback) {
        return api::ApiError{code.empty() ? fallback : std::move(code), e.message};
    };
    switch (e.code) {
    case ErrorCode::invalid_argument:
        return pick("invalid_parameter");
    case ErrorCode::too_large:
        return pick("too_large");
    case ErrorCode::unsupported:
        return pick("unsupported_media_type");
    case ErrorCode::unprocessable:
        return pick("unprocessable");
    case ErrorCode::not_found:
        return pick("not_found");
    case ErrorCode::no_space:
        return pick("insufficient_storage");
    case ErrorCode::unavailable:
        return pick("store_unavailable");
    case ErrorCode::cancelled:
        return pick("deadline_exceeded");
    case ErrorCode::io:
        return pick("storage_error");
    case ErrorCode::internal:
        break;
    }
    return pick("internal");
}

api::ApiError content_error(const Error& e, const char* invalid, const char* too_large) {
    switch (e.code) {
    case ErrorCode::too_large:
        return {too_large, e.message};
    case ErrorCode::unsupported:
        return {"unsupported_media_type", e.message};
    case ErrorCode::unprocessable:
        return {invalid, e.message};
    default:
        return to_api_error(e);
    }
}

namespace {
// Whether `pred` holds for one entity tag of an If-Match or If-None-Match list (RFC 9110 13.1),
// each trimmed of spaces and tabs.
template <typename Pred> bool any_tag(std::string_view header, Pred pred) {
    std::size_t pos = 0;
    while (pos < header.size()) {
        std::size_t end = header.find(',', pos);
        if (end == std::string_view::npos) end = header.size();
        std::string_view tag = header.substr(pos, end - pos);
        while (!tag.empty() && (tag.front() == ' ' || tag.front() == '\t')) tag.remove_prefix(1);
        while (!tag.empty() && (tag.back() == ' ' || tag.back() == '\t')) tag.remove_suffix(1);
        if (pred(tag)) return true;
        pos = end + 1;
    }
    return false;
}

std::string_view without_weak(std::string_view tag) {
    return tag.substr(0, 2) == "W/" ? tag.substr(2) : tag;
}
} // namespace

bool etag_matches(std::string_view header, std::string_view etag) {
    // Weak comparison (RFC 9110 13.1.2): W/"x" matches "x".
    const std::string_view bare = without_weak(etag);
    return any_tag(header,
                   [&](std::string_view tag) { return tag == "*" || without_weak(tag) == bare; });
}

bool if_match_holds(std::string_view header, std::string_view etag) {
    if (header.empty()) return true;
    // Strong comparison: a weak tag never matches, nor anything when there is no tag.
    const bool strong = !etag.empty() && etag.substr(0, 2) != "W/";
    return any_tag(header,
                   [&](std::string_view tag) { return tag == "*" || (strong && tag == etag); });
}

api::ApiError no_entity_tag(const char* what) {
    return {"precondition_failed", std::string("If-Match names entity tags, and a ") + what +
                                       " has none (content addressed, it never changes): "
                                       "send If-Match: * or no If-Match"};
}

const std::vector<std::pair<const char*, const char*>>& security_headers() {
    static const std::vector<std::pair<const char*, const char*>> headers = {
        {"X-Content-Type-Options", "nosniff"},
        {"Referrer-Policy", "no-referrer"},
        {"X-Frame-Options", "DENY"},
        {"Content-Security-Policy",
         "default-src 'self'; img-src 'self' data: blob:; style-src 'self' 'unsafe-inline'; "
         "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"},
    };
    return headers;
}

} // namespace textond::http
