#pragma once
// Surface noise without HTTP (texton-noise section 6): colours at 3D points with normals, and a
// preview of an OBJ mesh textured by it, with what each costs known before it runs. The routes
// (surface_routes.h) add the body, admission and the answer.
#include "api/requests.h"
#include "core/result.h"
#include "render/cancel.h"
#include "render/prepared_texton.h"
#include "render/renderer.h"
#include "render/surface_eval.h"

#include <string>
#include <string_view>
#include <vector>

namespace textond::app {

class SurfaceService {
public:
    explicit SurfaceService(render::Renderer& renderer);

    // CPU seconds for `points` points at p's MNI (admission's estimate).
    static double points_work_s(const render::PreparedTexton& texton, const api::SurfaceParams& p,
                                std::size_t points);
    // Colours at points with normals (3 floats a point each), the texton's channels interleaved;
    // `used` names where they were evaluated.
    Result<std::vector<float>> colours(const render::PreparedTexton& texton,
                                       const api::SurfaceParams& p,
                                       const std::vector<float>& points,
                                       const std::vector<float>& normals,
                                       const render::Cancel& cancel, std::string* used);

    // A mesh preview made ready: the parsed OBJ, the camera p asks for, and its cost
    // (triangles x the pixels they cover).
    struct Preview {
        core::TriangleMesh mesh;
        render::Camera camera;
        double work_s = 0;
    };
    // `relief`: a set's height bends the normals (twice the noise evaluations).
    static Result<Preview> preview(std::string_view obj, const render::PreparedTexton& texton,
                                   const api::SurfaceParams& p, bool relief = false);
    // The preview rendered and encoded as an 8-bit PNG; `height` (or null) a set's height map,
    // whose relief lights the mesh (render::Relief, with p.map.strength).
    Result<std::string> preview_png(const render::PreparedTexton& texton,
                                    const render::PreparedTexton* height, const Preview& preview,
                                    const api::SurfaceParams& p, const render::Cancel& cancel,
                                    std::string* used);

    // marginals=exemplar on a mesh preview's covered pixels (RGBA, alpha > 0 on the mesh).
    static void restore_covered(const core::MarginalTables& tables, core::Image& rgba);

private:
    render::Renderer& m_renderer;
};

} // namespace textond::app
