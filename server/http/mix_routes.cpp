// Texture mixes (texton-noise section 7): POST /v1/mixes from two textons, then the usual image
// endpoints under /v1/mixes/{id}/ (installed with the texton ones in image_routes.cpp).
#include "api/requests.h"
#include "core/texture_mix.h"
#include "server/http/http_support.h"
#include "server/http/service.h"
#include "server/io/image_io.h"
#include "server/io/mix_file.h"

namespace textond::http {

namespace {

nlohmann::json mix_json(const api::MixMeta& meta) {
    nlohmann::json j = meta;
    const std::string base = "/v1/mixes/" + meta.id;
    j["links"] = {{"self", base},
                  {"tilejson", base + "/tilejson.json"},
                  {"tiles", base + "/tiles/{z}/{x}/{y}.png"},
                  {"region", base + "/region.png"},
                  {"u", "/v1/textons/" + meta.u},
                  {"v", "/v1/textons/" + meta.v}};
    return j;
}

} // namespace

void Service::create_mix(const httplib::Request& req, httplib::Response& res,
                         const httplib::ContentReader& reader) {
    set_route("/v1/mixes");
    if (!authorised(req, res)) return;
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body)) return;
    const bool has_mask = !body.bytes.empty();
    api::MixRequest m;
    if (auto e = api::parse_mix(req.params, has_mask, m)) return send_error(res, *e);
    if (has_mask) {
        io::DecodeLimits limits;
        limits.max_pixels = m_config.max_pixels;
        limits.formats = m_config.formats;
        auto slot = m_gate.admit_decode(res);
        if (!slot) return;
        auto img = io::decode_image_memory(body.bytes, limits);
        if (!img) return send_error(res, content_error(img.error(), "invalid_mask"));
        m.field.mask = core::mask_from_image(img.value());
        if (auto err = m.field.validate())
            return send_error(res, {"invalid_parameter", err->message});
    }
    body.bytes = std::string();
    auto started = m_mix_service->start(m);
    if (!started) return send_error(res, to_api_error(started.error()));
    const MixService::Started& s = started.value();
    if (s.known) return send_json(res, 200, mix_json(*s.known));
    if (!s.submitted.job) return send_pool_full(res);
    const Result<AnalysisOutcome>& outcome = s.submitted.job->wait();
    if (!outcome) {
        const Error& err = outcome.error();
        return send_error(
            res,
            to_api_error(err, err.code == ErrorCode::invalid_argument ? "exemplar_too_small" : ""));
    }
    auto meta = m_mixes->meta(s.id);
    if (!meta) return send_error(res, to_api_error(meta.error()));
    const bool created = outcome.value().created && !s.submitted.joined;
    if (created) res.set_header("Location", "/v1/mixes/" + s.id);
    send_json(res, created ? 201 : 200, mix_json(meta.value()));
}

void Service::get_mix(const std::string& id, httplib::Response& res) {
    set_route("/v1/mixes/{id}");
    if (auto e = api::check_mix_id(id)) return send_error(res, *e);
    auto meta = m_mixes->meta(id);
    if (!meta) return send_error(res, to_api_error(meta.error()));
    send_json(res, 200, mix_json(meta.value()), "public, max-age=86400");
}

void Service::install_mix_routes() {
    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    using Reader = const httplib::ContentReader&;
    m_http.Post("/v1/mixes",
                [this](Req req, Res res, Reader reader) { create_mix(req, res, reader); });
    m_http.Get(R"(/v1/mixes/([^/]+))", [this](Req req, Res res) { get_mix(req.matches[1], res); });
    // Anything else under /v1/mixes/: a bad id is a 400 (never a path), a good one a 404.
    auto fallback = [](Req req, Res res) {
        set_route("/v1/mixes/*");
        const std::string rest = req.matches[1];
        const std::string first = rest.substr(0, rest.find('/'));
        if (auto e = api::check_mix_id(first)) return send_error(res, *e);
        send_error(res, {"not_found", "no such endpoint under /v1/mixes/" + first});
    };
    m_http.Get(R"(/v1/mixes/(.*))", fallback);
    // A content-reader route, so that cpp-httplib never reads a body nobody asked for.
    m_http.Post(R"(/v1/mixes/(.*))", [fallback](Req req, Res res, Reader) { fallback(req, res); });
}

} // namespace textond::http
