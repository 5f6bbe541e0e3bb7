#pragma once
// A triangle mesh as plain arrays (what the surface-noise preview draws).
#include <cstdint>
#include <vector>

namespace textond::core {

struct TriangleMesh {
    std::vector<float> positions;         // x, y, z per vertex
    std::vector<float> normals;           // per vertex (same count), or empty: face normals
    std::vector<std::uint32_t> triangles; // three vertex indices each
};

// Area-weighted vertex normals (smooth across shared vertices, so the surface noise's frame
// varies continuously over the mesh).
void smooth_normals(TriangleMesh& mesh);

} // namespace textond::core
