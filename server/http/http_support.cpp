#include "server/http/http_support.h"

#include "server/http/errors.h"

#include "api/safe_text.h"

#include <atomic>
#include <cstdio>
#include <ctime>
#include <random>

namespace textond::http {

RequestContext& current_request() {
    thread_local RequestContext ctx;
    return ctx;
}

namespace {
bool sane_request_id(const std::string& s) {
    if (s.empty() || s.size() > 64) return false;
    for (char c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.'))
            return false;
    return true;
}

} // namespace

std::string fresh_request_id() {
    // A per-process random prefix and a counter: unique, cheap, and sortable within a process.
    static const std::uint32_t prefix = std::random_device{}();
    static std::atomic<std::uint64_t> counter{0};
    char buf[32];
    std::snprintf(buf, sizeof buf, "%08x-%08llx", prefix,
                  static_cast<unsigned long long>(counter.fetch_add(1) + 1));
    return buf;
}

void begin_request(const httplib::Request& req) {
    RequestContext& ctx = current_request();
    const std::string given = req.get_header_value("X-Request-Id");
    ctx.id = sane_request_id(given) ? given : fresh_request_id();
    ctx.route = "unmatched";
    ctx.start = std::chrono::steady_clock::now();
    ctx.active = true;
    ctx.request = const_cast<httplib::Request*>(&req);
}

void set_route(const char* route_template) {
    current_request().route = route_template;
}

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

void fit_ranges(std::size_t size) {
    httplib::Request* req = current_request().request;
    if (!req || req->ranges.empty()) return;
    const auto n = static_cast<ssize_t>(size);
    for (auto& [first, last] : req->ranges) {
        if (first < 0 && last < 0) return req->ranges.clear();
        if (first < 0) { // the last `last` bytes
            first = std::max<ssize_t>(0, n - last);
            last = n - 1;
        } else if (last < 0 || last >= n) {
            last = n - 1;
        }
        if (first >= n || first > last) return req->ranges.clear();
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

bool etag_matches(std::string_view header, std::string_view etag) {
    if (header.empty()) return false;
    // Weak comparison (RFC 9110 13.1.2): W/"x" matches "x".
    std::string_view bare = etag;
    if (bare.substr(0, 2) == "W/") bare.remove_prefix(2);
    std::size_t pos = 0;
    while (pos < header.size()) {
        std::size_t end = header.find(',', pos);
        if (end == std::string_view::npos) end = header.size();
        std::string_view tag = header.substr(pos, end - pos);
        while (!tag.empty() && (tag.front() == ' ' || tag.front() == '\t')) tag.remove_prefix(1);
        while (!tag.empty() && (tag.back() == ' ' || tag.back() == '\t')) tag.remove_suffix(1);
        if (tag == "*") return true;
        if (tag.substr(0, 2) == "W/") tag.remove_prefix(2);
        if (tag == bare) return true;
        pos = end + 1;
    }
    return false;
}

std::vector<std::string> split_list(std::string_view s) {
    std::vector<std::string> out;
    std::size_t pos = 0;
    while (pos <= s.size()) {
        std::size_t end = s.find(',', pos);
        if (end == std::string_view::npos) end = s.size();
        std::string item(s.substr(pos, end - pos));
        item.erase(0, item.find_first_not_of(' '));
        item.erase(item.find_last_not_of(' ') + 1);
        if (!item.empty()) out.push_back(item);
        pos = end + 1;
    }
    return out;
}

namespace {
bool constant_time_equal(const std::string& a, const std::string& b) {
    unsigned char diff = a.size() == b.size() ? 0 : 1;
    const std::string& ref = a.size() == b.size() ? b : a;
    for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ ref[i]);
    return diff == 0;
}
} // namespace

bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res) {
    if (api_key.empty()) return true;
    const std::string h = req.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    if (h.size() > prefix.size() && h.compare(0, prefix.size(), prefix) == 0 &&
        constant_time_equal(h.substr(prefix.size()), api_key))
        return true;
    res.set_header("WWW-Authenticate", "Bearer realm=\"textond\"");
    send_error(res, {"unauthorized",
                     "this server needs an API key for writes: Authorization: Bearer <key>"});
    return false;
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
