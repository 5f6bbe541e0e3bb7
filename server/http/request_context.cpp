#include "server/http/request_context.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <random>
#include <utility>

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
    // Under If-Range the ranges wait for the answer's ETag (fit_ranges); an answer that never
    // fits them, having none, is sent whole.
    ctx.if_range_ranges.clear();
    if (req.has_header("If-Range")) std::swap(ctx.if_range_ranges, ctx.request->ranges);
}

void set_route(const char* route_template) {
    current_request().route = route_template;
}

void fit_ranges(const httplib::Response& res, std::size_t size) {
    RequestContext& ctx = current_request();
    httplib::Request* req = ctx.request;
    if (!req) return;
    if (!ctx.if_range_ranges.empty()) {
        const std::string validator = req->get_header_value("If-Range");
        const std::string etag = res.get_header_value("ETag");
        if (!etag.empty() && validator == etag && validator.rfind("W/", 0) != 0)
            req->ranges = std::move(ctx.if_range_ranges);
        ctx.if_range_ranges.clear();
    }
    if (req->ranges.empty()) return;
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

} // namespace textond::http
