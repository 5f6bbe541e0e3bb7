#include "server/http/surface_routes.h"

#include "api/requests.h"
#include "render/surface_eval.h"
#include "server/http/http_support.h"
#include "server/io/image_io.h"
#include "server/io/obj_mesh.h"

#include <cstring>

namespace textond::http {

namespace {

bool wants_binary(const httplib::Request& req) {
    return req.get_header_value("Accept").find("application/octet-stream") != std::string::npos;
}

// {"points": [[x, y, z], ...], "normals": [[x, y, z], ...]} or 6 little-endian float32 a point.
std::optional<api::ApiError> read_points(const httplib::Request& req, const std::string& body,
                                         std::vector<float>& points, std::vector<float>& normals) {
    const std::string type = req.get_header_value("Content-Type");
    if (type.find("application/json") != std::string::npos) {
        try {
            const auto j = nlohmann::json::parse(body);
            const auto& p = j.at("points");
            const auto& n = j.at("normals");
            if (!p.is_array() || !n.is_array() || p.size() != n.size())
                return api::ApiError{"invalid_body",
                                     "points and normals must be arrays of equal length"};
            if (p.size() > render::kMaxSurfacePoints)
                return api::ApiError{"payload_too_large", "at most 1000000 points"};
            for (std::size_t i = 0; i < p.size(); ++i)
                for (int d = 0; d < 3; ++d) {
                    points.push_back(p.at(i).at(static_cast<std::size_t>(d)).get<float>());
                    normals.push_back(n.at(i).at(static_cast<std::size_t>(d)).get<float>());
                }
        } catch (const std::exception& e) {
            return api::ApiError{"invalid_body",
                                 std::string("expected {\"points\": [[x,y,z],...], \"normals\": "
                                             "[[x,y,z],...]}: ") +
                                     e.what()};
        }
        return std::nullopt;
    }
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

SurfaceRoutes::SurfaceRoutes(TextonStore& store, render::Renderer& renderer, Gate& gate)
    : m_store(store), m_renderer(renderer), m_gate(gate) {}

void SurfaceRoutes::points(Req req, Res res, const httplib::ContentReader& reader) {
    set_route("/v1/textons/{id}/surface");
    const std::string id = req.matches[1].str();
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body)) return;
    api::SurfaceParams p;
    if (auto e = api::parse_surface(id, req.params, false, p)) return send_error(res, *e);
    auto prepared = m_store.prepared(id);
    if (!prepared) return send_error(res, to_api_error(prepared.error()));
    // Parsing a million JSON points takes hundreds of MB: inside the slot, like the evaluation.
    auto slot = m_gate.admit(res, 0.0);
    if (!slot) return;
    std::vector<float> points, normals;
    if (auto e = read_points(req, body.bytes, points, normals)) return send_error(res, *e);
    body.bytes = std::string();
    if (!m_gate.within_budget(res,
                              surface_work_s(points.size() / 3, p.mni, prepared.value()->order())))
        return;
    const render::Cancel cancel = m_gate.work_cancel();
    render::SurfaceRequest sr{p.seed, p.mni, p.scale, &cancel};
    const int nc = prepared.value()->channels();
    std::string evaluated_on;
    auto colours = m_renderer.surface(*prepared.value(), sr, points, normals, &evaluated_on);
    if (!colours) return m_gate.send_work_error(res, colours.error(), cancel);
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
    const std::string id = req.matches[1].str();
    Body body(m_gate.bodies());
    if (!m_gate.read_request_body(reader, res, body)) return;
    api::SurfaceParams p;
    if (auto e = api::parse_surface(id, req.params, true, p)) return send_error(res, *e);
    auto prepared = m_store.prepared(id);
    if (!prepared) return send_error(res, to_api_error(prepared.error()));
    auto slot = m_gate.admit(res, 0.0); // parsing, the view, rasterising and encoding
    if (!slot) return;
    auto mesh = io::parse_obj(body.bytes);
    if (!mesh)
        return send_error(res, content_error(mesh.error(), "invalid_mesh", "payload_too_large"));
    body.bytes = std::string();
    render::Camera cam;
    cam.fov_degrees = p.fov;
    if (p.camera) {
        cam.automatic = false;
        cam.eye = {p.eye[0], p.eye[1], p.eye[2]};
        cam.target = {p.target[0], p.target[1], p.target[2]};
    }
    const render::Cancel cancel = m_gate.work_cancel();
    render::SurfaceRequest sr{p.seed, p.mni, p.scale, &cancel};
    {
        // What the preview costs is known before it runs: triangles x the pixels they cover.
        auto view = render::mesh_view(mesh.value(), sr, cam, p.width, p.height);
        if (!view)
            return send_error(res,
                              content_error(view.error(), "invalid_mesh", "payload_too_large"));
        const std::uint64_t tests =
            render::mesh_raster_tests(mesh.value(), view.value(), p.width, p.height);
        if (!m_gate.within_budget(res, mesh_work_s(tests, std::int64_t{p.width} * p.height, p.mni,
                                                   prepared.value()->order())))
            return;
    }
    std::string evaluated_on;
    auto image = m_renderer.mesh_preview(*prepared.value(), sr, mesh.value(), cam, p.width,
                                         p.height, &evaluated_on);
    if (!image) return m_gate.send_work_error(res, image.error(), cancel);
    auto png = io::encode_image_memory(image.value(), io::Encoding::png8);
    if (!png) return send_error(res, to_api_error(png.error()));
    res.set_header("X-Textond-Backend", evaluated_on);
    res.set_content(png.value(), "image/png");
}

} // namespace textond::http
