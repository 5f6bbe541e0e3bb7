#pragma once
// Surface noise (texton-noise paper, section 6, Proposition 3): texton noise on a surface without
// texture coordinates. A 3D grid Poisson process is projected onto the tangent plane of the query
// point y; point x_i adds eps_i (1 - 2 |<y - x_i, n>| / r)+ h(<y - x_i, u1>, <y - x_i, u2>), with
// (u1, u2, n) a frame that varies continuously with the normal n. With random signs the mean is
// exactly m, and dividing by sqrt(lambda r / 3) gives the variance integral h^2 of the 2D noise
// (Prop. 3); the mean number of impacts is lambda r^3 (MNI, 60 by default as in the paper).
#include "core/texton.h"

#include <array>
#include <cstdint>
#include <vector>

namespace textond::core {

inline constexpr double kDefaultSurfaceMni = 60.0;

using Vec3 = std::array<double, 3>;

// An orthonormal (u1, u2) completing the unit normal n (Frisvad 2012): continuous on the sphere
// except at n = (0, 0, -1), where no continuous tangent field can exist (the hairy ball theorem).
void tangent_frame(const Vec3& n, Vec3& u1, Vec3& u2);

struct SurfaceStats {
    std::uint64_t points = 0;  // Poisson points looked at
    std::uint64_t impacts = 0; // points inside the r-cube around y (weight > 0, |z| < r/2)
};

class SurfaceNoise {
public:
    // `texton` must outlive this object.
    SurfaceNoise(const Texton& texton, double mni = kDefaultSurfaceMni);

    // The noise's colour at y (texels) with unit normal n; `out` gets the texton's channels.
    void eval(std::uint64_t seed, const Vec3& y, const Vec3& n, float* out,
              SurfaceStats* stats = nullptr) const;

    // The gradient of channel 0 at y within the tangent plane (per texel, world axes): what a
    // material set's height bends the normals by (render/surface_eval.h, Relief). Orders 1 and
    // 3; zero for order 0, whose texton is piecewise constant.
    Vec3 gradient(std::uint64_t seed, const Vec3& y, const Vec3& n) const;

    int cell_size() const { return m_a; }
    double lambda() const { return m_lambda; }
    double norm() const { return m_norm; } // 1 / sqrt(lambda r / 3)
    const std::vector<std::uint32_t>& thresholds() const { return m_thresholds; }

private:
    void h(double z1, double z2, double* v) const; // h(z + centre) per channel, the centred texton
    void dh(double z1, double z2, double g[2]) const; // d h / d z1, d z2 of channel 0
    template <typename F>
    void for_each_impact(std::uint64_t seed, const Vec3& y, const Vec3& n, const Vec3& u1,
                         const Vec3& u2, SurfaceStats* stats, F&& f) const;
    const Texton& m_t;
    int m_a;
    double m_lambda, m_norm;
    std::vector<std::uint32_t> m_thresholds;
};

// Key of 3D cell (cx, cy, cz): a hash domain of its own (not a 2D cell_key).
std::uint32_t cell_key3(std::uint64_t seed, std::int64_t cx, std::int64_t cy, std::int64_t cz);

} // namespace textond::core
