#include "core/triangle_mesh.h"

#include <cmath>

namespace textond::core {

void smooth_normals(TriangleMesh& m) {
    m.normals.assign(m.positions.size(), 0.0f);
    std::vector<double> acc(m.positions.size(), 0.0);
    for (std::size_t t = 0; t + 2 < m.triangles.size(); t += 3) {
        const std::size_t a = 3 * std::size_t{m.triangles[t]},
                          b = 3 * std::size_t{m.triangles[t + 1]},
                          c = 3 * std::size_t{m.triangles[t + 2]};
        double e1[3], e2[3];
        for (int d = 0; d < 3; ++d) {
            e1[d] = double(m.positions[b + d]) - m.positions[a + d];
            e2[d] = double(m.positions[c + d]) - m.positions[a + d];
        }
        // The cross product's length is twice the area: the weighting comes for free.
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
        for (std::size_t v : {a, b, c})
            for (int d = 0; d < 3; ++d) acc[v + static_cast<std::size_t>(d)] += n[d];
    }
    for (std::size_t v = 0; v + 2 < acc.size(); v += 3) {
        const double len =
            std::sqrt(acc[v] * acc[v] + acc[v + 1] * acc[v + 1] + acc[v + 2] * acc[v + 2]);
        for (int d = 0; d < 3; ++d)
            m.normals[v + static_cast<std::size_t>(d)] =
                len > 0 ? static_cast<float>(acc[v + static_cast<std::size_t>(d)] / len) : 0.0f;
    }
}

} // namespace textond::core
