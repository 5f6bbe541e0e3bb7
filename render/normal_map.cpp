#include "render/normal_map.h"

#include <algorithm>
#include <cmath>

namespace textond::render {

namespace {

// Limit levels: central differences of the level's field over a window one pixel wider.
Result<bool> limit_gradient(CpuBackend& cpu, const PreparedTexton& height, const NoiseRequest& q,
                            core::Image& gx, core::Image& gy) {
    NoiseRequest w = q;
    w.x0 -= 1;
    w.y0 -= 1;
    w.width += 2;
    w.height += 2;
    if (auto err = height.check(w)) return *err;
    auto v = cpu.render(height, w);
    if (!v) return v.error();
    const core::Image& f = v.value();
    const float inv = static_cast<float>(1.0 / (2.0 * std::ldexp(1.0, q.level)));
    gx = core::Image(q.width, q.height, 1);
    gy = core::Image(q.width, q.height, 1);
    for (int y = 0; y < q.height; ++y)
        for (int x = 0; x < q.width; ++x) {
            gx.at(0, x, y) = (f.at(0, x + 2, y + 1) - f.at(0, x, y + 1)) * inv;
            gy.at(0, x, y) = (f.at(0, x + 1, y + 2) - f.at(0, x + 1, y)) * inv;
        }
    return true;
}

} // namespace

Result<core::Image> render_normal_map(CpuBackend& cpu, const PreparedTexton& height,
                                      const NoiseRequest& q, double strength) {
    if (height.channels() != 1)
        return make_error(ErrorCode::invalid_argument, "normals come from a one-channel height");
    if (height.order() == 0)
        return make_error(ErrorCode::invalid_argument,
                          "a texton of interpolation order 0 has no gradient: normal maps need "
                          "order 1 or 3");
    if (!(strength > 0.0 && strength <= core::kMaxNormalStrength))
        return make_error(ErrorCode::invalid_argument, "strength must be in (0, 1000]");
    if (auto err = height.check(q)) return *err;
    core::Image gx, gy;
    if (q.level >= height.limit_level()) {
        auto ok = limit_gradient(cpu, height, q, gx, gy);
        if (!ok) return ok.error();
    } else {
        auto x = cpu.render_gradient(height, q, 0);
        if (!x) return x.error();
        auto y = cpu.render_gradient(height, q, 1);
        if (!y) return y.error();
        gx = std::move(x.value());
        gy = std::move(y.value());
    }
    core::Image out(q.width, q.height, 3);
    for (std::size_t k = 0; k < out.plane_size(); ++k) {
        const double nx = -strength * gx.data[k], ny = strength * gy.data[k];
        const double inv = 1.0 / std::sqrt(nx * nx + ny * ny + 1.0);
        out.plane(0)[k] = static_cast<float>(0.5 * nx * inv + 0.5);
        out.plane(1)[k] = static_cast<float>(0.5 * ny * inv + 0.5);
        out.plane(2)[k] = static_cast<float>(0.5 * inv + 0.5);
    }
    return out;
}

void renormalise_normal_map(core::Image& normals) {
    for (std::size_t k = 0; k < normals.plane_size(); ++k) {
        double n[3], len = 0;
        for (int c = 0; c < 3; ++c) {
            n[c] = 2.0 * normals.plane(c)[k] - 1.0;
            len += n[c] * n[c];
        }
        len = len > 0 ? 1.0 / std::sqrt(len) : 0.0;
        for (int c = 0; c < 3; ++c)
            normals.plane(c)[k] = static_cast<float>(0.5 * n[c] * len + 0.5);
    }
}

core::Image shade_lit(const core::Image& albedo, const core::Image& normals, double azimuth_deg,
                      double elevation_deg) {
    const double az = azimuth_deg * M_PI / 180.0, el = elevation_deg * M_PI / 180.0;
    const double l[3] = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
    core::Image out(albedo.width, albedo.height, 3);
    for (std::size_t k = 0; k < out.plane_size(); ++k) {
        double dot = 0.0;
        for (int c = 0; c < 3; ++c) dot += (2.0 * normals.plane(c)[k] - 1.0) * l[c];
        const double shade = 0.35 + 0.65 * std::max(0.0, dot);
        for (int c = 0; c < 3; ++c)
            out.plane(c)[k] =
                static_cast<float>(albedo.plane(albedo.channels == 3 ? c : 0)[k] * shade);
    }
    return out;
}

} // namespace textond::render
