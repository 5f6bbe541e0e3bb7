#include "server/app/surface_service.h"

#include "server/app/slots.h"
#include "server/app/work_cost.h"
#include "server/io/image_io.h"
#include "server/io/obj_mesh.h"

#include <cmath>

namespace textond::app {

SurfaceService::SurfaceService(render::Renderer& renderer) : m_renderer(renderer) {}

namespace {

// marginals=exemplar on surface noise: level 0's tables (surface noise has the plane noise's
// covariance, texton-noise paper Proposition 3), pointwise; null for the Gaussian default.
Result<std::shared_ptr<const core::MarginalTables>>
surface_tables(const render::PreparedTexton& texton, const api::SurfaceParams& p) {
    if (!p.exemplar_marginals) return std::shared_ptr<const core::MarginalTables>();
    auto tables = texton.marginals(0);
    if (!tables)
        return make_error(ErrorCode::invalid_argument,
                          "marginals=exemplar needs the exemplar's marginals, which this texton "
                          "does not keep (analysed before they were kept); use marginals=gaussian");
    return tables;
}

} // namespace

double SurfaceService::points_work_s(const render::PreparedTexton& texton,
                                     const api::SurfaceParams& p, std::size_t points) {
    return surface_work_s(points, p.mni, texton.order());
}

Result<std::vector<float>>
SurfaceService::colours(const render::PreparedTexton& texton, const api::SurfaceParams& p,
                        const std::vector<float>& points, const std::vector<float>& normals,
                        const render::Cancel& cancel, std::string* used) {
    auto tables = surface_tables(texton, p);
    if (!tables) return tables.error();
    const render::SurfaceRequest sr{p.seed, p.mni, p.scale, &cancel};
    auto colours = m_renderer.surface(texton, sr, points, normals, used);
    if (colours && tables.value()) {
        const auto nc = static_cast<std::size_t>(texton.channels());
        for (std::size_t k = 0; k + nc <= colours.value().size(); k += nc)
            tables.value()->apply(colours.value().data() + k);
    }
    return colours;
}

Result<SurfaceService::Preview> SurfaceService::preview(std::string_view obj,
                                                        const render::PreparedTexton& texton,
                                                        const api::SurfaceParams& p, bool relief) {
    auto mesh = io::parse_obj(obj);
    if (!mesh) return mesh.error();
    Preview out;
    out.mesh = std::move(mesh.value());
    out.camera.fov_degrees = p.fov;
    if (p.light) {
        const double az = p.map.azimuth * M_PI / 180.0, el = p.map.elevation * M_PI / 180.0;
        out.camera.light = {std::cos(el) * std::cos(az), std::sin(el), std::cos(el) * std::sin(az)};
    }
    if (p.camera) {
        out.camera.automatic = false;
        out.camera.eye = {p.eye[0], p.eye[1], p.eye[2]};
        out.camera.target = {p.target[0], p.target[1], p.target[2]};
    }
    const render::SurfaceRequest sr{p.seed, p.mni, p.scale, nullptr};
    auto view = render::mesh_view(out.mesh, sr, out.camera, p.width, p.height);
    if (!view) return view.error();
    const std::uint64_t tests =
        render::mesh_raster_tests(out.mesh, view.value(), p.width, p.height);
    out.work_s = mesh_work_s(tests, std::int64_t{p.width} * p.height, p.mni, texton.order()) *
                 (relief ? 2.0 : 1.0);
    return out;
}

// The mesh's pixels (alpha > 0) of an RGBA preview; grey textons repeat their channel.
void SurfaceService::restore_covered(const core::MarginalTables& tables, core::Image& rgba) {
    const int nc = tables.channels();
    for (int y = 0; y < rgba.height; ++y)
        for (int x = 0; x < rgba.width; ++x) {
            if (!(rgba.at(3, x, y) > 0.0f)) continue;
            float v[3] = {rgba.at(0, x, y), rgba.at(1, x, y), rgba.at(2, x, y)};
            tables.apply(v);
            for (int c = 0; c < 3; ++c) rgba.at(c, x, y) = v[std::min(c, nc - 1)];
        }
}

Result<std::string> SurfaceService::preview_png(const render::PreparedTexton& texton,
                                                const render::PreparedTexton* height,
                                                const Preview& preview, const api::SurfaceParams& p,
                                                const render::Cancel& cancel, std::string* used) {
    auto tables = surface_tables(texton, p);
    if (!tables) return tables.error();
    const render::SurfaceRequest sr{p.seed, p.mni, p.scale, &cancel};
    const render::Relief relief{height ? &height->texton() : nullptr, p.map.strength};
    auto image = m_renderer.mesh_preview(texton, sr, preview.mesh, preview.camera, p.width,
                                         p.height, used, relief);
    if (!image) return image.error();
    if (tables.value()) restore_covered(*tables.value(), image.value());
    return io::encode_image_memory(image.value(), io::Encoding::png8);
}

} // namespace textond::app
