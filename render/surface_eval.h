#pragma once
// Surface noise at many points (texton-noise section 6): the per-point evaluation of
// core/surface_noise.h spread over threads, and a preview of a triangle mesh textured by it.
// CPU only for now.
#include "core/image.h"
#include "core/material_set.h"
#include "core/result.h"
#include "core/surface_noise.h"
#include "core/texton.h"
#include "core/triangle_mesh.h"
#include "render/cancel.h"

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace textond::render {

inline constexpr std::size_t kMaxSurfacePoints = 1'000'000;

struct SurfaceRequest {
    std::uint64_t seed = 0;
    double mni = core::kDefaultSurfaceMni;
    double scale = 1.0;             // texels per unit of the positions
    const Cancel* cancel = nullptr; // when to give up (render/cancel.h); none = run to the end
};

// Why `points` and `normals` cannot be evaluated (lengths, limits, NaN, zero normals), or nothing.
std::optional<Error> check_surface_input(const SurfaceRequest& req,
                                         const std::vector<float>& points,
                                         const std::vector<float>& normals);

// `points` and `normals` hold x, y, z per point (normals need not be unit length, must not be
// zero); returns the texton's channels per point.
Result<std::vector<float>> evaluate_surface(const core::Texton& texton, const SurfaceRequest& req,
                                            const std::vector<float>& points,
                                            const std::vector<float>& normals, int threads = 0);

using Mesh = core::TriangleMesh;

struct Camera {
    core::Vec3 eye{0, 0, 0}, target{0, 0, 0}, up{0, 1, 0};
    double fov_degrees = 35;
    bool automatic = true;           // frame the mesh's bounding box from the front, slightly above
    core::Vec3 light{0.4, 0.8, 0.6}; // towards the one directional light (world; any length)
};

// A perspective view of the mesh, each visible pixel the surface noise at its interpolated
// position and normal (positions times req.scale; scale 0 = the bounding box's diagonal spans 512
// texels), lit by one directional light; the background is transparent (alpha 0, RGBA output).
// Where the camera is and how it projects: the CPU rasteriser and GlBackend::mesh_preview share it.
struct MeshView {
    core::Vec3 eye{0, 0, 0}, fwd{0, 0, -1}, right{1, 0, 0}, up{0, 1, 0};
    double focal = 1;                  // 1 / tan(fov / 2)
    double aspect = 1;                 // width / height
    double scale = 1;                  // texels per mesh unit
    double near_z = 0.01, far_z = 100; // depths (along fwd) covering the mesh in front of the eye
    core::Vec3 light{0, 1, 0};         // the camera's light, unit
    // The OpenGL clip transform, row-major.
    std::array<float, 16> mvp() const;
};
Result<MeshView> mesh_view(const Mesh& mesh, const SurfaceRequest& req, Camera camera, int width,
                           int height);

// Pixels the rasteriser tests for `mesh` in this view: the sum of its triangles' screen boxes.
// What a preview costs before the noise, known before any of it runs (the service refuses
// meshes over its work budget: a few kB of stacked screen-sized quads took 46 s).
std::uint64_t mesh_raster_tests(const Mesh& mesh, const MeshView& view, int width, int height);

// Relief for a material set's preview: the surface noise of the set's height map (same seed, the
// same process: one r) bends each pixel's normal, n' = normalize(n - strength grad h), with grad h
// the height's gradient in the tangent plane (core::SurfaceNoise::gradient), as map=normal bends
// the plane's; the light then shades n'. CPU only.
struct Relief {
    const core::Texton* height = nullptr; // none: the mesh's own normals
    double strength = core::kDefaultNormalStrength;
};

Result<core::Image> render_mesh_preview(const core::Texton& texton, const SurfaceRequest& req,
                                        const Mesh& mesh, Camera camera, int width, int height,
                                        int threads = 0, const Relief& relief = {});

} // namespace textond::render
