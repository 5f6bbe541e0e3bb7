#include "server/http/splat_routes.h"

#include "api/requests.h"
#include "server/http/auth.h"
#include "server/http/request_body.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/io/image_io.h"
#include "server/io/splat_file.h"

#include <algorithm>

namespace textond::http {

namespace {

nlohmann::json splat_json(const api::SplatMeta& meta) {
    nlohmann::json j = meta;
    const std::string base = "/v1/splats/" + meta.id;
    nlohmann::json layers = nlohmann::json::array();
    for (const std::string& t : meta.textons) layers.push_back("/v1/textons/" + t);
    j["links"] = {{"self", base},
                  {"tilejson", base + "/tilejson.json"},
                  {"tiles", base + "/tiles/{z}/{x}/{y}.png"},
                  {"region", base + "/region.png"},
                  {"quality_png", base + "/quality.png"},
                  {"textons", layers}};
    return j;
}

} // namespace

SplatRoutes::SplatRoutes(const ServeConfig& config, SplatService& service, SplatStore& splats,
                         ImageCache& cache, Gate& gate)
    : m_config(config), m_service(service), m_splats(splats), m_cache(cache), m_gate(gate) {}

void SplatRoutes::create(Req req, Res res, const httplib::ContentReader& reader) {
    set_route("/v1/splats");
    if (!authorised(m_config.api_key, req, res)) return;
    if (!req.is_multipart_form_data())
        return send_error(res, {"unsupported_media_type",
                                "a splat is a multipart/form-data body: textons, and weights (an "
                                "image) or rules (JSON)"});
    Body counted(m_gate.bodies());
    std::vector<httplib::MultipartFormData> parts;
    if (auto e = read_parts(reader, m_config.max_upload_bytes, res.status, counted, parts)) {
        if (e->code == "overloaded") res.set_header("Retry-After", "1");
        return send_error(res, *e);
    }
    // The weight images are files; every other part is a field, as in the query.
    api::Query fields = req.params;
    const httplib::MultipartFormData* images[2] = {nullptr, nullptr};
    for (const auto& part : parts) {
        const int slot = part.name == "weights" ? 0 : part.name == "weights2" ? 1 : -1;
        if (slot < 0) {
            fields.emplace(part.name, part.content);
            continue;
        }
        if (images[slot])
            return send_error(
                res, {"invalid_parameter", "more than one '" + part.name + "' field in the form"});
        if (part.content.empty())
            return send_error(res, {"empty_body", "the '" + part.name + "' field is empty"});
        images[slot] = &part;
    }
    if (images[1] && !images[0])
        return send_error(res, {"invalid_parameter", "'weights2' comes after 'weights'"});
    const int sent = images[1] ? 2 : images[0] ? 1 : 0;
    api::SplatRequest request;
    if (auto e = api::parse_splat(fields, sent, request)) return send_error(res, *e);
    Admitted admitted;
    if (sent > 0 &&
        !admit_weights(res, images, sent, static_cast<int>(request.textons.size()), admitted))
        return;
    auto created = m_service.create(request, admitted.encoded, admitted.limits);
    if (!created) return send_error(res, content_error(created.error(), "invalid_weights"));
    const auto& c = created.value();
    if (c.created) res.set_header("Location", "/v1/splats/" + c.meta.id);
    send_json(res, c.created ? 201 : 200, splat_json(c.meta));
}

bool SplatRoutes::admit_weights(Res res, const httplib::MultipartFormData* const* images, int sent,
                                int layers, Admitted& out) {
    // The stored weights' own limits, and --max-pixels when that is lower.
    out.limits = io::splat_weight_limits(m_config.formats);
    out.limits.max_pixels = std::min<std::uint64_t>(m_config.max_pixels, out.limits.max_pixels);
    std::vector<io::ImageHeader> headers;
    for (int i = 0; i < sent; ++i) {
        auto h = io::image_header_memory(images[i]->content, out.limits);
        if (!h) {
            send_error(res, content_error(h.error(), "invalid_weights"));
            return false;
        }
        headers.push_back(h.value());
        out.encoded.emplace_back(images[i]->content);
    }
    out.lease = m_gate.lease_decode(res, SplatService::creation_bytes(headers, layers));
    if (!out.lease) return false;
    auto slot = m_gate.admit_decode(res);
    if (!slot) return false;
    out.slot.emplace(std::move(*slot));
    return true;
}

void SplatRoutes::get(Req req, Res res) {
    set_route("/v1/splats/{id}");
    const std::string id = req.matches[1].str();
    if (auto e = api::check_splat_id(id)) return send_error(res, *e);
    auto meta = m_splats.meta(id);
    if (!meta) return send_error(res, to_api_error(meta.error()));
    send_json(res, 200, splat_json(meta.value()), "no-cache"); // its layers may be deleted
}

void SplatRoutes::remove(Req req, Res res) {
    set_route("/v1/splats/{id}");
    const std::string id = req.matches[1].str();
    if (!authorised(m_config.api_key, req, res)) return;
    if (auto e = api::check_splat_id(id)) return send_error(res, *e);
    if (!if_match_holds(req.get_header_value("If-Match"), "") && m_splats.contains(id))
        return send_error(res, no_entity_tag("splat"));
    auto r = m_splats.remove(id);
    if (!r) return send_error(res, to_api_error(r.error()));
    m_cache.erase_texton(id); // its images, by their source's id
    res.status = 204;
}

void SplatRoutes::fallback(Req req, Res res) {
    set_route("/v1/splats/*");
    const std::string rest = req.matches[1];
    const std::string first = rest.substr(0, rest.find('/'));
    if (auto e = api::check_splat_id(first)) return send_error(res, *e);
    send_error(res, {"not_found", "no such endpoint under /v1/splats/" + first});
}

} // namespace textond::http
