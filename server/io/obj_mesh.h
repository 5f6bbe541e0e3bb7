#pragma once
// Wavefront OBJ (positions and faces; texture coordinates and normals in the file are ignored:
// surface noise needs none, and smooth normals are recomputed so the frame is continuous).
#include "core/result.h"
#include "core/triangle_mesh.h"

#include <string_view>

namespace textond::io {

inline constexpr std::size_t kMaxObjVertices = 2'000'000;
inline constexpr std::size_t kMaxObjTriangles = 4'000'000;

// Polygons become triangle fans; negative indices count from the end (OBJ's relative form).
Result<core::TriangleMesh> parse_obj(std::string_view text);

} // namespace textond::io
