#pragma once
// A material set's normal map, from its height map exactly: the derivative of the interpolation
// kernel applied to the height's level table gives the gradient at every pixel (CpuBackend::
// render_gradient), so normal tiles are windows onto one function, as seamless and deterministic
// as the height's. Tangent space, OpenGL convention (+Y up, as Blender and Unity read it):
//   n = normalize(-s dh/dx, +s dh/drow, 1), stored as n / 2 + 1/2 in RGB,
// with h the height map's values (0..1) and s the strength: the texels that a height step of 1
// spans. At limit levels (the texton spans under two pixels, NOISE_SPEC.md section 6) the field
// is the limit model's and the gradient is its central difference over two pixels, a function
// of the pixel too.
#include "core/image.h"
#include "core/material_set.h"
#include "core/result.h"
#include "render/cpu_backend.h"
#include "render/noise_request.h"
#include "render/prepared_texton.h"

namespace textond::render {

Result<core::Image> render_normal_map(CpuBackend& cpu, const PreparedTexton& height,
                                      const NoiseRequest& request, double strength);

// A normal map (n / 2 + 1/2) whose normals were mixed (a resampled tileable texture) made of
// unit normals again.
void renormalise_normal_map(core::Image& normals);

// The lit preview of a set (map=lit): each pixel of `albedo` (grey or RGB) times
// 0.35 + 0.65 max(0, n . l), the mesh preview's shading, with n decoded from `normals` (a
// render_normal_map of the same window) and l the unit light from azimuth (degrees,
// counter-clockwise from +x, +y up) and elevation (degrees above the surface). Pointwise, so lit
// tiles stitch as their maps do.
core::Image shade_lit(const core::Image& albedo, const core::Image& normals, double azimuth_deg,
                      double elevation_deg);

} // namespace textond::render
