#include "server/http/mix_routes.h"

#include <algorithm>
#include <memory>

#include "api/requests.h"
#include "core/texture_mix.h"
#include "server/http/auth.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
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

MixRoutes::MixRoutes(const ServeConfig& config, MixService& service, MixStore& mixes,
                     AnalysisPool& pool, ImageCache& cache, Gate& gate)
    : m_config(config), m_service(service), m_mixes(mixes), m_pool(pool), m_cache(cache),
      m_gate(gate) {}

bool MixRoutes::read_mask(Res res, const std::string& bytes, api::MixRequest& m,
                          std::shared_ptr<BudgetLease>& lease) {
    io::DecodeLimits limits;
    limits.max_pixels = m_config.max_pixels;
    limits.formats = m_config.formats;
    // The decode (ImageHeader::decode_bytes) and the mask made from it (4 bytes a pixel) are
    // reserved from the decode budget first, and held while the mix waits for and runs its
    // analysis: twelve 22 KB masks of 4096 x 4096 are decoded within the budget, not all at once.
    if (auto h = io::image_header_memory(bytes, limits)) {
        const auto px =
            static_cast<std::size_t>(h.value().width) * static_cast<std::size_t>(h.value().height);
        lease = m_gate.lease_decode(res, h.value().decode_bytes + px * 4);
        if (!lease) return false;
    }
    auto slot = m_gate.admit_decode(res);
    if (!slot) return false;
    auto img = io::decode_image_memory(bytes, limits);
    if (!img) {
        send_error(res, content_error(img.error(), "invalid_mask"));
        return false;
    }
    m.field.mask = core::mask_from_image(img.value());
    if (auto err = m.field.validate()) {
        send_error(res, {"invalid_parameter", err->message});
        return false;
    }
    return true;
}

void MixRoutes::create(Req req, Res res, const httplib::ContentReader& reader) {
    set_route("/v1/mixes");
    if (!authorised(m_config.api_key, req, res)) return;
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body)) return;
    const bool has_mask = !body.bytes.empty();
    api::MixRequest m;
    if (auto e = api::parse_mix(req.params, has_mask, m)) return send_error(res, *e);
    std::shared_ptr<BudgetLease> mask_lease; // held until the answer
    if (has_mask && !read_mask(res, body.bytes, m, mask_lease)) return;
    body.bytes = std::string();
    auto started = m_service.start(m, [&](double work_s) {
        return m_gate.within_budget(res, work_s, 1.0,
                                    "fewer levels, or textons analysed with fewer iterations");
    });
    if (!started) return send_error(res, to_api_error(started.error()));
    const MixService::Started& s = started.value();
    if (s.known) return send_json(res, 200, mix_json(*s.known));
    if (s.refused) return; // 413 sent
    if (!s.submitted.job) return m_gate.pool_full(res, m_pool);
    const Result<AnalysisOutcome>& outcome = s.submitted.job->wait();
    if (!outcome) {
        const Error& err = outcome.error();
        return send_error(
            res,
            to_api_error(err, err.code == ErrorCode::invalid_argument ? "exemplar_too_small" : ""));
    }
    auto meta = m_mixes.meta(s.id);
    if (!meta) return send_error(res, to_api_error(meta.error()));
    const bool created = outcome.value().created && !s.submitted.joined;
    if (created) res.set_header("Location", "/v1/mixes/" + s.id);
    send_json(res, created ? 201 : 200, mix_json(meta.value()));
}

void MixRoutes::get(Req req, Res res) {
    set_route("/v1/mixes/{id}");
    const std::string id = req.matches[1].str();
    if (auto e = api::check_mix_id(id)) return send_error(res, *e);
    auto meta = m_mixes.meta(id);
    if (!meta) return send_error(res, to_api_error(meta.error()));
    send_json(res, 200, mix_json(meta.value()), "no-cache"); // it may be deleted
}

void MixRoutes::remove(Req req, Res res) {
    set_route("/v1/mixes/{id}");
    const std::string id = req.matches[1].str();
    if (!authorised(m_config.api_key, req, res)) return;
    if (auto e = api::check_mix_id(id)) return send_error(res, *e);
    if (!if_match_holds(req.get_header_value("If-Match"), "") && m_mixes.contains(id))
        return send_error(res, no_entity_tag("mix"));
    auto r = m_mixes.remove(id);
    if (!r) return send_error(res, to_api_error(r.error()));
    m_cache.erase_texton(id); // its images, by their source's id
    res.status = 204;
}

void MixRoutes::fallback(Req req, Res res) {
    set_route("/v1/mixes/*");
    const std::string rest = req.matches[1];
    const std::string first = rest.substr(0, rest.find('/'));
    if (auto e = api::check_mix_id(first)) return send_error(res, *e);
    send_error(res, {"not_found", "no such endpoint under /v1/mixes/" + first});
}

} // namespace textond::http
