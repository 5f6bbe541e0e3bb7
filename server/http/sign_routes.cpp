#include "server/http/sign_routes.h"

#include "api/sign_request.h"
#include "server/app/url_signing.h"
#include "server/http/auth.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"

#include <chrono>

namespace textond::http {

SignRoutes::SignRoutes(const ServeConfig& config, Gate& gate) : m_config(config), m_gate(gate) {}

void SignRoutes::sign(const httplib::Request& req, httplib::Response& res,
                      const httplib::ContentReader& reader) {
    set_route("/v1/sign");
    const std::string& key = m_config.url_signing_key;
    if (!key.empty() && m_config.api_key.empty())
        return send_error(res, {"signing_unavailable",
                                "this server signs URLs only for holders of its --api-key, and "
                                "was started without one: sign with `textond sign` instead"});
    if (!authorised(m_config.api_key, req, res)) return;
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body, api::kMaxSignBodyBytes)) return;
    api::SignRequest r;
    if (auto e = api::parse_sign(body.bytes, r)) return send_error(res, *e);
    if (key.empty()) return send_json(res, 200, {{"urls", r.urls}, {"signed", false}});
    const std::int64_t exp = std::chrono::duration_cast<std::chrono::seconds>(
                                 std::chrono::system_clock::now().time_since_epoch())
                                 .count() +
                             r.expires_in;
    std::vector<std::string> signed_urls;
    for (std::size_t i = 0; i < r.urls.size(); ++i) {
        auto u = sign_url(key, r.urls[i], exp);
        if (!u)
            return send_error(
                res, {"invalid_body", "urls[" + std::to_string(i) + "]: " + u.error().message});
        signed_urls.push_back(std::move(u.value()));
    }
    send_json(res, 200, {{"urls", signed_urls}, {"signed", true}, {"exp", exp}});
}

} // namespace textond::http
