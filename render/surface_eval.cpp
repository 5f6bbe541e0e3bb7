#include "render/surface_eval.h"

#include "core/fft2d.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace textond::render {

namespace {

using core::Vec3;

Vec3 sub(const Vec3& a, const Vec3& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(const Vec3& a, const Vec3& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
bool normalise(Vec3& v) {
    const double n = std::sqrt(dot(v, v));
    if (!(n > 0) || !std::isfinite(n)) return false;
    for (double& c : v) c /= n;
    return true;
}

std::optional<Error> check_request(const SurfaceRequest& req) {
    if (!(req.mni >= 1 && req.mni <= 200))
        return make_error(ErrorCode::invalid_argument, "mni must be in [1, 200]");
    if (!(req.scale >= 0 && req.scale <= 1e9) || !std::isfinite(req.scale))
        return make_error(ErrorCode::invalid_argument, "scale must be in [0, 1e9]");
    return std::nullopt;
}

} // namespace

std::optional<Error> check_surface_input(const SurfaceRequest& req,
                                         const std::vector<float>& points,
                                         const std::vector<float>& normals) {
    if (auto e = check_request(req)) return e;
    if (points.size() % 3 != 0 || normals.size() != points.size())
        return make_error(ErrorCode::invalid_argument,
                          "points and normals must be equally many x, y, z triples");
    const std::size_t n = points.size() / 3;
    if (n > kMaxSurfacePoints)
        return make_error(ErrorCode::too_large,
                          "at most " + std::to_string(kMaxSurfacePoints) + " points a request");
    const double lim = 4.0e15; // positions stay exact to a 24-bit fraction in double
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!std::isfinite(points[i]) || std::fabs(points[i] * req.scale) > lim)
            return make_error(ErrorCode::invalid_argument,
                              "point " + std::to_string(i / 3) + " is not finite or too far out");
        if (!std::isfinite(normals[i]))
            return make_error(ErrorCode::invalid_argument,
                              "normal " + std::to_string(i / 3) + " is not finite");
    }
    for (std::size_t i = 0; i < n; ++i)
        if (!(std::fabs(normals[3 * i]) + std::fabs(normals[3 * i + 1]) +
                  std::fabs(normals[3 * i + 2]) >
              0))
            return make_error(ErrorCode::invalid_argument,
                              "normal " + std::to_string(i) + " has zero length");
    return std::nullopt;
}

Result<std::vector<float>> evaluate_surface(const core::Texton& texton, const SurfaceRequest& req,
                                            const std::vector<float>& points,
                                            const std::vector<float>& normals, int threads) {
    if (auto e = check_surface_input(req, points, normals)) return *e;
    const std::size_t n = points.size() / 3;
    const double scale = req.scale > 0 ? req.scale : 1.0;
    const core::SurfaceNoise noise(texton, req.mni);
    const int nc = texton.channels;
    std::vector<float> out(n * static_cast<std::size_t>(nc));
    std::atomic<bool> skipped{false};
#pragma omp parallel for schedule(dynamic, 64) num_threads(core::resolve_threads(threads))
    for (std::size_t i = 0; i < n; ++i) {
        if (i % 64 == 0 && stopped(req.cancel)) skipped = true;
        if (skipped) continue;
        Vec3 nn = {normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]};
        normalise(nn); // finite and non-zero: check_surface_input said so
        const Vec3 y = {points[3 * i] * scale, points[3 * i + 1] * scale,
                        points[3 * i + 2] * scale};
        noise.eval(req.seed, y, nn, &out[i * static_cast<std::size_t>(nc)]);
    }
    if (skipped) return abandoned(req.cancel, "the evaluation");
    return out;
}

std::array<float, 16> MeshView::mvp() const {
    // Camera space looks down -z: x = <d, right>, y = <d, up>, z = -<d, fwd>, d = p - eye.
    const double v[4][4] = {{right[0], right[1], right[2], -dot(right, eye)},
                            {up[0], up[1], up[2], -dot(up, eye)},
                            {-fwd[0], -fwd[1], -fwd[2], dot(fwd, eye)},
                            {0, 0, 0, 1}};
    const double n = near_z, f = far_z;
    const double p[4][4] = {{focal / aspect, 0, 0, 0},
                            {0, focal, 0, 0},
                            {0, 0, (f + n) / (n - f), 2 * f * n / (n - f)},
                            {0, 0, -1, 0}};
    std::array<float, 16> m{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0;
            for (int k = 0; k < 4; ++k) s += p[i][k] * v[k][j];
            m[static_cast<std::size_t>(i * 4 + j)] = static_cast<float>(s);
        }
    return m;
}

Result<MeshView> mesh_view(const Mesh& mesh, const SurfaceRequest& req, Camera cam, int width,
                           int height) {
    if (auto e = check_request(req)) return *e;
    if (width < 16 || height < 16 || width > 2048 || height > 2048)
        return make_error(ErrorCode::invalid_argument, "preview sides must be in [16, 2048]");
    const std::size_t nv = mesh.positions.size() / 3;
    if (nv == 0 || mesh.triangles.empty())
        return make_error(ErrorCode::invalid_argument, "the mesh has no triangles");
    Vec3 lo = {1e300, 1e300, 1e300}, hi = {-1e300, -1e300, -1e300};
    for (std::size_t v = 0; v < nv; ++v)
        for (int d = 0; d < 3; ++d) {
            const double p = mesh.positions[3 * v + static_cast<std::size_t>(d)];
            lo[static_cast<std::size_t>(d)] = std::min(lo[static_cast<std::size_t>(d)], p);
            hi[static_cast<std::size_t>(d)] = std::max(hi[static_cast<std::size_t>(d)], p);
        }
    const Vec3 centre = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
    const double diag = std::sqrt(dot(sub(hi, lo), sub(hi, lo)));
    if (!(diag > 0)) return make_error(ErrorCode::invalid_argument, "the mesh is a single point");
    MeshView v;
    v.scale = req.scale > 0 ? req.scale : 512.0 / diag;
    if (cam.automatic) {
        cam.target = centre;
        const double dist = 0.5 * diag / std::tan(cam.fov_degrees * 3.14159265358979 / 360) * 1.1;
        Vec3 dir = {0.0, 0.35, 1.0};
        normalise(dir);
        cam.eye = {centre[0] + dist * dir[0], centre[1] + dist * dir[1], centre[2] + dist * dir[2]};
        cam.up = {0, 1, 0};
    }
    v.eye = cam.eye;
    v.fwd = sub(cam.target, cam.eye);
    if (!normalise(v.fwd)) return make_error(ErrorCode::invalid_argument, "eye equals target");
    v.right = cross(v.fwd, cam.up);
    if (!normalise(v.right)) return make_error(ErrorCode::invalid_argument, "up is along the view");
    v.up = cross(v.right, v.fwd);
    v.light = cam.light;
    if (!normalise(v.light))
        return make_error(ErrorCode::invalid_argument, "the light has no direction");
    v.focal = 1.0 / std::tan(cam.fov_degrees * 3.14159265358979 / 360);
    v.aspect = static_cast<double>(width) / height;
    double zmin = 1e300, zmax = -1e300;
    for (std::size_t i = 0; i < nv; ++i) {
        const double z =
            dot(sub({mesh.positions[3 * i], mesh.positions[3 * i + 1], mesh.positions[3 * i + 2]},
                    v.eye),
                v.fwd);
        zmin = std::min(zmin, z);
        zmax = std::max(zmax, z);
    }
    if (!(zmax > 0)) return make_error(ErrorCode::invalid_argument, "the mesh is behind the eye");
    v.far_z = zmax * 1.01 + 1e-9 * diag;
    v.near_z = std::max(zmin * 0.99, v.far_z * 1e-4);
    return v;
}

namespace {

// Screen x, y in pixels and depth along the view of every vertex.
void project_vertices(const Mesh& mesh, const MeshView& mv, int width, int height,
                      std::vector<double>& sx, std::vector<double>& sy, std::vector<double>& sz) {
    const std::size_t nv = mesh.positions.size() / 3;
    sx.assign(nv, 0.0);
    sy.assign(nv, 0.0);
    sz.assign(nv, 0.0);
    for (std::size_t v = 0; v < nv; ++v) {
        const Vec3 p = {mesh.positions[3 * v], mesh.positions[3 * v + 1],
                        mesh.positions[3 * v + 2]};
        const Vec3 d = sub(p, mv.eye);
        const double z = dot(d, mv.fwd);
        sz[v] = z;
        const double x = dot(d, mv.right) * mv.focal / (z * mv.aspect),
                     y = dot(d, mv.up) * mv.focal / z;
        sx[v] = (x + 1) * 0.5 * width;
        sy[v] = (1 - y) * 0.5 * height;
    }
}

// Pixel bounds of a triangle's box, clamped to the screen in double before any cast: a vertex
// just in front of the eye projects to 1e300 pixels, and casting that to int is undefined.
int screen_floor(double v, int n) {
    return v > 0 ? static_cast<int>(std::floor(std::min(v, double(n - 1)))) : 0;
}
int screen_ceil(double v, int n) {
    return v < n - 1 ? (v > 0 ? static_cast<int>(std::ceil(v)) : 0) : n - 1;
}

} // namespace

std::uint64_t mesh_raster_tests(const Mesh& mesh, const MeshView& mv, int width, int height) {
    std::vector<double> sx, sy, sz;
    project_vertices(mesh, mv, width, height, sx, sy, sz);
    std::uint64_t total = 0;
    for (std::size_t t = 0; t + 2 < mesh.triangles.size(); t += 3) {
        const std::uint32_t i[3] = {mesh.triangles[t], mesh.triangles[t + 1],
                                    mesh.triangles[t + 2]};
        if (sz[i[0]] <= 1e-9 || sz[i[1]] <= 1e-9 || sz[i[2]] <= 1e-9) continue;
        const double lx = std::min({sx[i[0]], sx[i[1]], sx[i[2]]});
        const double hx = std::max({sx[i[0]], sx[i[1]], sx[i[2]]});
        const double ly = std::min({sy[i[0]], sy[i[1]], sy[i[2]]});
        const double hy = std::max({sy[i[0]], sy[i[1]], sy[i[2]]});
        const int bx0 = screen_floor(lx, width), bx1 = screen_ceil(hx, width);
        const int by0 = screen_floor(ly, height), by1 = screen_ceil(hy, height);
        if (bx1 < bx0 || by1 < by0) continue;
        total +=
            static_cast<std::uint64_t>(bx1 - bx0 + 1) * static_cast<std::uint64_t>(by1 - by0 + 1);
    }
    return total;
}

namespace {

// Each pixel's nearest triangle (-1: none) and its perspective-correct barycentrics.
struct ZBuffer {
    std::vector<std::int64_t> tri;
    std::vector<double> bary;
};

// The projected triangles rasterised into `zb`; false when `cancel` stopped it.
bool rasterise(const Mesh& mesh, const std::vector<double>& sx, const std::vector<double>& sy,
               const std::vector<double>& sz, int width, int height, const Cancel* cancel,
               ZBuffer& zb) {
    const std::size_t npx = static_cast<std::size_t>(width) * height;
    std::vector<double> depth(npx, std::numeric_limits<double>::infinity());
    std::vector<std::int64_t>& tri = zb.tri;
    std::vector<double>& bary = zb.bary;
    tri.assign(npx, -1);
    bary.assign(npx * 3, 0.0);
    const std::size_t nt = mesh.triangles.size() / 3;
    for (std::size_t t = 0; t < nt; ++t) {
        if (stopped(cancel)) return false;
        const std::uint32_t i0 = mesh.triangles[3 * t], i1 = mesh.triangles[3 * t + 1],
                            i2 = mesh.triangles[3 * t + 2];
        if (sz[i0] <= 1e-9 || sz[i1] <= 1e-9 || sz[i2] <= 1e-9) continue; // behind the eye
        const double x0 = sx[i0], y0 = sy[i0], x1 = sx[i1], y1 = sy[i1], x2 = sx[i2], y2 = sy[i2];
        const double area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
        if (std::fabs(area) < 1e-12) continue;
        const int bx0 = screen_floor(std::min({x0, x1, x2}), width);
        const int bx1 = screen_ceil(std::max({x0, x1, x2}), width);
        const int by0 = screen_floor(std::min({y0, y1, y2}), height);
        const int by1 = screen_ceil(std::max({y0, y1, y2}), height);
        for (int py = by0; py <= by1; ++py)
            for (int px = bx0; px <= bx1; ++px) {
                const double cx = px + 0.5, cy = py + 0.5;
                double w0 = ((x1 - cx) * (y2 - cy) - (x2 - cx) * (y1 - cy)) / area;
                double w1 = ((x2 - cx) * (y0 - cy) - (x0 - cx) * (y2 - cy)) / area;
                double w2 = 1 - w0 - w1;
                if (w0 < 0 || w1 < 0 || w2 < 0) continue;
                // Perspective-correct weights from the screen-space ones.
                const double q0 = w0 / sz[i0], q1 = w1 / sz[i1], q2 = w2 / sz[i2];
                const double qs = q0 + q1 + q2;
                const double z = 1 / qs;
                const std::size_t k = static_cast<std::size_t>(py) * width + px;
                if (z >= depth[k]) continue;
                depth[k] = z;
                tri[k] = static_cast<std::int64_t>(t);
                bary[3 * k] = q0 / qs;
                bary[3 * k + 1] = q1 / qs;
                bary[3 * k + 2] = q2 / qs;
            }
    }
    return true;
}

} // namespace

Result<core::Image> render_mesh_preview(const core::Texton& texton, const SurfaceRequest& req,
                                        const Mesh& mesh, Camera cam, int width, int height,
                                        int threads, const Relief& relief) {
    auto view = mesh_view(mesh, req, cam, width, height);
    if (!view) return view.error();
    const MeshView& mv = view.value();
    const double scale = mv.scale;

    std::vector<double> sx, sy, sz;
    project_vertices(mesh, mv, width, height, sx, sy, sz);
    // Z-buffer of (triangle, barycentrics) per pixel; then one noise evaluation per pixel.
    ZBuffer zb;
    if (!rasterise(mesh, sx, sy, sz, width, height, req.cancel, zb))
        return abandoned(req.cancel, "the evaluation");
    const std::vector<std::int64_t>& tri = zb.tri;
    const std::vector<double>& bary = zb.bary;
    // Every visible pixel's surface point and normal, then one evaluation of them all.
    std::vector<std::size_t> where;
    std::vector<double> ys;
    std::vector<float> ns;
    std::vector<float> shade;
    const Vec3& light = mv.light;
    for (int py = 0; py < height; ++py)
        for (int px = 0; px < width; ++px) {
            const std::size_t k = static_cast<std::size_t>(py) * width + px;
            if (tri[k] < 0) continue;
            const auto t = static_cast<std::size_t>(tri[k]);
            const std::uint32_t idx[3] = {mesh.triangles[3 * t], mesh.triangles[3 * t + 1],
                                          mesh.triangles[3 * t + 2]};
            Vec3 p = {0, 0, 0}, n = {0, 0, 0};
            for (int j = 0; j < 3; ++j) {
                const double w = bary[3 * k + static_cast<std::size_t>(j)];
                for (int d = 0; d < 3; ++d) {
                    p[static_cast<std::size_t>(d)] +=
                        w * mesh.positions[3 * idx[j] + static_cast<std::size_t>(d)];
                    if (!mesh.normals.empty())
                        n[static_cast<std::size_t>(d)] +=
                            w * mesh.normals[3 * idx[j] + static_cast<std::size_t>(d)];
                }
            }
            if (mesh.normals.empty() || !normalise(n)) {
                const Vec3 a = {mesh.positions[3 * idx[0]], mesh.positions[3 * idx[0] + 1],
                                mesh.positions[3 * idx[0] + 2]};
                const Vec3 b = {mesh.positions[3 * idx[1]], mesh.positions[3 * idx[1] + 1],
                                mesh.positions[3 * idx[1] + 2]};
                const Vec3 c = {mesh.positions[3 * idx[2]], mesh.positions[3 * idx[2] + 1],
                                mesh.positions[3 * idx[2] + 2]};
                n = cross(sub(b, a), sub(c, a));
                if (!normalise(n)) continue;
            }
            if (dot(n, mv.fwd) > 0) n = {-n[0], -n[1], -n[2]}; // face the camera
            where.push_back(k);
            for (int d = 0; d < 3; ++d) {
                ys.push_back(p[static_cast<std::size_t>(d)] * scale);
                ns.push_back(static_cast<float>(n[static_cast<std::size_t>(d)]));
            }
            shade.push_back(static_cast<float>(0.35 + 0.65 * std::max(0.0, dot(n, light))));
        }
    const int nc = texton.channels;
    const int stride = nc;
    std::vector<float> colours(where.size() * static_cast<std::size_t>(nc));
    const core::SurfaceNoise noise(texton, req.mni);
    std::optional<core::SurfaceNoise> bump;
    if (relief.height) bump.emplace(*relief.height, req.mni);
    std::atomic<bool> skipped{false};
#pragma omp parallel for schedule(dynamic, 256) num_threads(core::resolve_threads(threads))
    for (std::size_t i = 0; i < where.size(); ++i) {
        if (i % 256 == 0 && stopped(req.cancel)) skipped = true;
        if (skipped) continue;
        const Vec3 y = {ys[3 * i], ys[3 * i + 1], ys[3 * i + 2]};
        const Vec3 n = {ns[3 * i], ns[3 * i + 1], ns[3 * i + 2]};
        noise.eval(req.seed, y, n, &colours[i * static_cast<std::size_t>(nc)]);
        if (!bump) continue;
        const Vec3 g = bump->gradient(req.seed, y, n);
        Vec3 bent = {n[0] - relief.strength * g[0], n[1] - relief.strength * g[1],
                     n[2] - relief.strength * g[2]};
        normalise(bent);
        shade[i] = static_cast<float>(0.35 + 0.65 * std::max(0.0, dot(bent, light)));
    }
    if (skipped) return abandoned(req.cancel, "the evaluation");
    core::Image out(width, height, 4);
    for (std::size_t i = 0; i < where.size(); ++i) {
        const int px = static_cast<int>(where[i] % static_cast<std::size_t>(width));
        const int py = static_cast<int>(where[i] / static_cast<std::size_t>(width));
        for (int c = 0; c < 3; ++c)
            out.at(c, px, py) = std::clamp(
                colours[i * static_cast<std::size_t>(stride) + (nc == 3 ? c : 0)] * shade[i], 0.0f,
                1.0f);
        out.at(3, px, py) = 1.0f;
    }
    return out;
}

} // namespace textond::render
