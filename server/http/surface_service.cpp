#include "server/http/surface_service.h"

#include "server/http/admission.h"
#include "server/io/image_io.h"
#include "server/io/obj_mesh.h"

namespace textond::http {

SurfaceService::SurfaceService(render::Renderer& renderer) : m_renderer(renderer) {}

double SurfaceService::points_work_s(const render::PreparedTexton& texton,
                                     const api::SurfaceParams& p, std::size_t points) {
    return surface_work_s(points, p.mni, texton.order());
}

Result<std::vector<float>>
SurfaceService::colours(const render::PreparedTexton& texton, const api::SurfaceParams& p,
                        const std::vector<float>& points, const std::vector<float>& normals,
                        const render::Cancel& cancel, std::string* used) {
    const render::SurfaceRequest sr{p.seed, p.mni, p.scale, &cancel};
    return m_renderer.surface(texton, sr, points, normals, used);
}

Result<SurfaceService::Preview> SurfaceService::preview(std::string_view obj,
                                                        const render::PreparedTexton& texton,
                                                        const api::SurfaceParams& p) {
    auto mesh = io::parse_obj(obj);
    if (!mesh) return mesh.error();
    Preview out;
    out.mesh = std::move(mesh.value());
    out.camera.fov_degrees = p.fov;
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
    out.work_s = mesh_work_s(tests, std::int64_t{p.width} * p.height, p.mni, texton.order());
    return out;
}

Result<std::string> SurfaceService::preview_png(const render::PreparedTexton& texton,
                                                const Preview& preview, const api::SurfaceParams& p,
                                                const render::Cancel& cancel, std::string* used) {
    const render::SurfaceRequest sr{p.seed, p.mni, p.scale, &cancel};
    auto image =
        m_renderer.mesh_preview(texton, sr, preview.mesh, preview.camera, p.width, p.height, used);
    if (!image) return image.error();
    return io::encode_image_memory(image.value(), io::Encoding::png8);
}

} // namespace textond::http
