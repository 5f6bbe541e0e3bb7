#include "server/http/surface_routes.h"

#include "api/json_body.h"
#include "api/requests.h"
#include "server/http/auth.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/io/image_io.h"

#include <cstring>
#include <utility>

namespace textond::http {

namespace {

bool wants_binary(const httplib::Request& req) {
    return req.get_header_value("Accept").find("application/octet-stream") != std::string::npos;
}

// {"points": [[x, y, z], ...], "normals": [[x, y, z], ...]} or 6 little-endian float32 a point.
std::optional<api::ApiError> read_points(const httplib::Request& req, const std::string& body,
                                         std::vector<float>& points, std::vector<float>& normals) {
    const std::string type = req.get_header_value("Content-Type");
    if (type.find("application/json") != std::string::npos)
        return api::parse_surface_json(body, render::kMaxSurfacePoints, points, normals);
    if (body.size() % 24 != 0)
        return api::ApiError{"invalid_body",
                             "a binary body is 6 little-endian float32 a point (x y z nx ny nz), "
                             "or send application/json"};
    const std::size_t n = body.size() / 24;
    if (n > render::kMaxSurfacePoints)
        return api::ApiError{"payload_too_large", "at most 1000000 points"};
    std::vector<float> all(n * 6);
    std::memcpy(all.data(), body.data(), body.size());
    for (std::size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d) {
            points.push_back(all[6 * i + static_cast<std::size_t>(d)]);
            normals.push_back(all[6 * i + 3 + static_cast<std::size_t>(d)]);
        }
    return std::nullopt;
}

} // namespace

SurfaceRoutes::SurfaceRoutes(TextonStore& store, SurfaceService& surfaces, Gate& gate,
                             std::string api_key)
    : m_store(store), m_surfaces(surfaces), m_gate(gate), m_api_key(std::move(api_key)) {}

void SurfaceRoutes::points(Req req, Res res, const httplib::ContentReader& reader) {
    set_route("/v1/textons/{id}/surface");
    if (!authorised(m_api_key, req, res)) return;
    const std::string id = req.matches[1].str();
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body)) return;
    api::SurfaceParams p;
    if (auto e = api::parse_surface(id, req.params, false, p)) return send_error(res, *e);
    auto prepared = render::map_view(m_store.prepared(id), p.map.name);
    if (!prepared) return send_error(res, to_api_error(prepared.error()));
    const render::PreparedTexton& texton = *prepared.value();
    // Parsing a million JSON points takes hundreds of MB: inside the slot, like the evaluation.
    auto slot = m_gate.admit(res, 0.0);
    if (!slot) return;
    std::vector<float> points, normals;
    if (auto e = read_points(req, body.bytes, points, normals)) return send_error(res, *e);
    body.bytes = std::string();
    if (!m_gate.within_budget(res, SurfaceService::points_work_s(texton, p, points.size() / 3)))
        return;
    const render::Cancel cancel = m_gate.work_cancel();
    std::string evaluated_on;
    auto colours = m_surfaces.colours(texton, p, points, normals, cancel, &evaluated_on);
    if (!colours) return m_gate.send_work_error(res, colours.error(), cancel);
    const int nc = texton.channels();
    res.set_header("X-Textond-Channels", std::to_string(nc));
    res.set_header("X-Textond-Backend", evaluated_on);
    if (wants_binary(req)) {
        std::string out(colours.value().size() * sizeof(float), '\0');
        std::memcpy(out.data(), colours.value().data(), out.size());
        return res.set_content(out, "application/octet-stream");
    }
    nlohmann::json list = nlohmann::json::array();
    const auto& c = colours.value();
    for (std::size_t i = 0; i < c.size(); i += static_cast<std::size_t>(nc)) {
        nlohmann::json one = nlohmann::json::array();
        for (int k = 0; k < nc; ++k) one.push_back(c[i + static_cast<std::size_t>(k)]);
        list.push_back(one);
    }
    send_json(res, 200, {{"channels", nc}, {"mni", p.mni}, {"seed", p.seed}, {"colors", list}},
              "no-store");
}

void SurfaceRoutes::mesh(Req req, Res res, const httplib::ContentReader& reader) {
    set_route("/v1/textons/{id}/mesh.png");
    if (!authorised(m_api_key, req, res)) return;
    const std::string id = req.matches[1].str();
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body)) return;
    api::SurfaceParams p;
    if (auto e = api::parse_surface(id, req.params, true, p)) return send_error(res, *e);
    auto set = m_store.prepared(id);
    if (!set) return send_error(res, to_api_error(set.error()));
    // A set's mesh: coloured by a map (albedo by default) and, with a height, lit through its
    // relief unless a map is named.
    const auto& maps = set.value()->texton().maps;
    // Order 0 is piecewise constant: no gradient, so no relief (asked for: a clear 400).
    const bool smooth = set.value()->order() != 0;
    if (p.map.name == core::kLitMap && !smooth)
        return send_error(res, {"invalid_parameter",
                                "a texton of interpolation order 0 has no gradient: map=lit "
                                "needs order 1 or 3"});
    const bool relief = p.map.name == core::kLitMap ||
                        (p.map.name.empty() && smooth && core::find_map(maps, core::kHeightMap));
    auto prepared = render::map_view(set, relief ? std::string() : p.map.name);
    if (!prepared) return send_error(res, to_api_error(prepared.error()));
    if (relief && maps.empty())
        return send_error(res, {"invalid_parameter",
                                "map=lit needs a material set with a height map; this texton has "
                                "one exemplar"});
    auto height = relief ? render::map_view(set, core::kHeightMap) : prepared;
    if (!height) return send_error(res, to_api_error(height.error()));
    const render::PreparedTexton& texton = *prepared.value();
    // Admitted at no cost: the cost is known only once the mesh is parsed (a parse the body limit
    // bounds), and within_budget refuses it below before anything is rasterised.
    auto slot = m_gate.admit(res, 0.0); // parsing, the view, rasterising and encoding
    if (!slot) return;
    auto preview = SurfaceService::preview(body.bytes, texton, p, relief);
    if (!preview)
        return send_error(res, content_error(preview.error(), "invalid_mesh", "payload_too_large"));
    body.bytes = std::string();
    if (!m_gate.within_budget(res, preview.value().work_s)) return;
    const render::Cancel cancel = m_gate.work_cancel();
    std::string evaluated_on;
    auto png = m_surfaces.preview_png(texton, relief ? height.value().get() : nullptr,
                                      preview.value(), p, cancel, &evaluated_on);
    if (!png) return m_gate.send_work_error(res, png.error(), cancel);
    res.set_header("X-Textond-Backend", evaluated_on);
    res.set_content(png.value(), "image/png");
}

} // namespace textond::http
