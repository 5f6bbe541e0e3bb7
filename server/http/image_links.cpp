#include "server/http/image_links.h"

#include "server/app/url_signing.h"
#include "server/http/auth.h"
#include "server/http/responses.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace textond::http {

namespace {
constexpr const char* kImmutable = "public, max-age=31536000, immutable";
} // namespace

ImageLinks::ImageLinks(const ServeConfig& config, Metrics& metrics, const int& port)
    : m_config(config), m_metrics(metrics), m_port(port),
      m_limiter(config.render_rate / 60.0, config.render_burst) {
    if (m_limiter.enabled())
        m_metrics.gauge("textond_rate_limited_clients",
                        "Clients with a render bucket (--render-rate).",
                        [this] { return static_cast<double>(m_limiter.clients()); });
}

std::optional<api::Query> ImageLinks::served_query(const httplib::Request& req,
                                                   httplib::Response& res,
                                                   std::string_view format) const {
    const bool signing = !m_config.url_signing_key.empty();
    if (signing) {
        const auto now = std::chrono::duration_cast<std::chrono::seconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
        if (auto e = check_signature(m_config.url_signing_key, req.path, req.params, now)) {
            send_error(res, *e);
            return std::nullopt;
        }
    }
    api::Query q;
    if (!m_config.presets.empty()) {
        if (auto e = apply_preset(m_config.presets, req.params, format, q)) {
            send_error(res, *e);
            return std::nullopt;
        }
        return q;
    }
    for (const auto& [k, v] : req.params)
        if (!signing || (k != "sig" && k != "exp")) q.emplace(k, v);
    return q;
}

std::string ImageLinks::signed_link(const httplib::Request& req,
                                    const std::string& path_and_query) const {
    if (m_config.url_signing_key.empty()) return path_and_query;
    std::int64_t exp = 0;
    if (const auto e = req.params.find("exp"); e != req.params.end())
        exp = api::parse_i64(e->second).value_or(0);
    auto signed_url = sign_url(m_config.url_signing_key, path_and_query, exp);
    return signed_url ? signed_url.value() : path_and_query;
}

bool ImageLinks::within_rate(const httplib::Request& req, httplib::Response& res) {
    double wait = 0;
    if (m_limiter.take(rate_client(req), wait)) return true;
    m_metrics.not_admitted("rate_limited");
    res.set_header("Retry-After", std::to_string(std::max(1, static_cast<int>(std::ceil(wait)))));
    send_error(res, {"rate_limited", "this client starts at most " +
                                         std::to_string(m_config.render_rate) +
                                         " renders a minute (cached images are not counted)"});
    return false;
}

std::string ImageLinks::rate_client(const httplib::Request& req) const {
    // Any other token would be a fresh bucket for the asking: only the server's key counts.
    if (holds_api_key(m_config.api_key, req)) return "api-key";
    // IPv6: a /64 is one client (anyone holding one has 2^64 addresses).
    const std::string& a = req.remote_addr;
    if (a.find(':') != std::string::npos) {
        std::size_t at = 0;
        for (int groups = 0; groups < 4 && at != std::string::npos; ++groups)
            at = a.find(':', at + (groups ? 1 : 0));
        return "net6:" + a.substr(0, at);
    }
    return "addr:" + a;
}

std::string ImageLinks::cache_control_for(const httplib::Request& req) const {
    const auto exp = req.params.find("exp");
    if (m_config.url_signing_key.empty() || exp == req.params.end()) return kImmutable;
    const auto now = std::chrono::duration_cast<std::chrono::seconds>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count();
    // At most a year, as immutable images: an exp far in the future is no reason for more.
    const std::int64_t until = std::max<std::int64_t>(0, api::parse_i64(exp->second).value_or(0));
    const std::int64_t left = std::clamp<std::int64_t>(until - now, 0, 31'536'000);
    return "public, max-age=" + std::to_string(left);
}

std::string ImageLinks::base_url(const httplib::Request& req) const {
    if (!m_config.public_url.empty()) {
        std::string u = m_config.public_url;
        while (!u.empty() && u.back() == '/') u.pop_back();
        return u;
    }
    std::string host = req.get_header_value("Host");
    bool sane = !host.empty() && host.size() < 256 &&
                host.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                       "0123456789.-:[]") == std::string::npos;
    // A port, if any, is 1..65535 (x:99999999 was echoed into every tile URL).
    if (const auto colon = host.rfind(':');
        sane && colon != std::string::npos && host.find(']', colon) == std::string::npos) {
        const std::string port = host.substr(colon + 1);
        sane = !port.empty() && port.size() <= 5 &&
               port.find_first_not_of("0123456789") == std::string::npos && std::stoi(port) >= 1 &&
               std::stoi(port) <= 65535;
    }
    if (!sane) host = m_config.host + ":" + std::to_string(m_port);
    return "http://" + host;
}

} // namespace textond::http
