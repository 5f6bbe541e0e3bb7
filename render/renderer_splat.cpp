// Renderer::splat: the weights of every pixel, then each layer that shows in the window rendered
// as a texton window of its own seed and blended (core/splat_blend.h). Every step is a function
// of the pixel, so strips, tiles and regions of one splat agree bit for bit. The per-pixel math
// runs as loops over planes, a pixel per vector lane, doing core's operations in core's order
// (the same bits as core::normalise_weights and core::blend_layers; no FMA contraction), cloned
// per instruction set like the CPU backend's splats.
#include "core/placed_image.h"
#include "render/image_buffers.h"
#include "render/prepared_splat.h"
#include "render/renderer.h"
#include "render/thread_scratch.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace textond::render {

namespace {

constexpr std::int64_t kStripPixels = std::int64_t{1} << 20;

// Cloned per instruction set like the CPU backend's splats. This file is compiled with
// -fno-trapping-math and -fno-math-errno (render/CMakeLists.txt), which let GCC turn the loops'
// selects into vector blends and sqrt into an instruction; neither changes a result.
#define TEXTOND_VECTOR_KERNEL __attribute__((target_clones("avx512f", "avx2", "default")))

std::vector<float>& thread_scratch() {
    static thread_local std::vector<float> v;
    return v;
}

// core::normalise_weights on every pixel: w holds k planes of n.
TEXTOND_VECTOR_KERNEL void normalise_planes(int k, std::size_t n, float* __restrict w,
                                            float* __restrict sum) {
    for (std::size_t i = 0; i < n; ++i) sum[i] = 0.0f;
    for (int l = 0; l < k; ++l) {
        float* __restrict p = w + n * l;
        for (std::size_t i = 0; i < n; ++i) {
            p[i] = p[i] > 0.0f ? p[i] : 0.0f;
            sum[i] += p[i];
        }
    }
    constexpr float kMax = std::numeric_limits<float>::max();
    for (int l = 0; l < k; ++l) {
        float* __restrict p = w + n * l;
        const float alone = l == 0 ? 1.0f : 0.0f;
        for (std::size_t i = 0; i < n; ++i)
            p[i] = !(sum[i] > 0.0f) || !(sum[i] <= kMax) ? alone : p[i] / sum[i];
    }
}

// Raw weights to what the blend adds: core::normalise_weights, the blended mean of each channel
// (into out[0..2]) and core::blend_coefficients (in place of the weights), for every pixel in one
// pass with a pixel's K weights in registers.
template <int K>
inline __attribute__((always_inline)) void
blend_setup_k(std::size_t n, float* __restrict w, const float (*mean)[3], float* __restrict o0,
              float* __restrict o1, float* __restrict o2) {
    constexpr float kMax = std::numeric_limits<float>::max();
    for (std::size_t i = 0; i < n; ++i) {
        float v[K];
        float sum = 0.0f;
        for (int l = 0; l < K; ++l) {
            const float x = w[n * l + i];
            v[l] = x > 0.0f ? x : 0.0f;
            sum += v[l];
        }
        const bool none = !(sum > 0.0f) || !(sum <= kMax);
        for (int l = 0; l < K; ++l) v[l] = none ? (l == 0 ? 1.0f : 0.0f) : v[l] / sum;
        float m0 = 0.0f, m1 = 0.0f, m2 = 0.0f, w2 = 0.0f;
        for (int l = 0; l < K; ++l) {
            m0 += v[l] * mean[l][0];
            m1 += v[l] * mean[l][1];
            m2 += v[l] * mean[l][2];
        }
        for (int l = 0; l < K; ++l) w2 += v[l] * v[l];
        const float s = w2 > 0.0f ? 1.0f / std::sqrt(w2) : 0.0f;
        o0[i] = m0;
        o1[i] = m1;
        o2[i] = m2;
        for (int l = 0; l < K; ++l) w[n * l + i] = v[l] * s;
    }
}

TEXTOND_VECTOR_KERNEL void blend_setup(int k, std::size_t n, float* w, const float (*mean)[3],
                                       float* const* out) {
    switch (k) {
    case 2:
        return blend_setup_k<2>(n, w, mean, out[0], out[1], out[2]);
    case 3:
        return blend_setup_k<3>(n, w, mean, out[0], out[1], out[2]);
    case 4:
        return blend_setup_k<4>(n, w, mean, out[0], out[1], out[2]);
    case 5:
        return blend_setup_k<5>(n, w, mean, out[0], out[1], out[2]);
    case 6:
        return blend_setup_k<6>(n, w, mean, out[0], out[1], out[2]);
    case 7:
        return blend_setup_k<7>(n, w, mean, out[0], out[1], out[2]);
    default:
        return blend_setup_k<8>(n, w, mean, out[0], out[1], out[2]);
    }
}

// One channel of one layer of core::blend_layers onto o: the layer's value where it alone shows,
// nothing where it does not show, else + c (v - m).
TEXTOND_VECTOR_KERNEL void add_layer(std::size_t n, const float* __restrict c,
                                     const float* __restrict v, float m, float* __restrict o) {
    for (std::size_t i = 0; i < n; ++i) {
        const float a = o[i] + c[i] * (v[i] - m);
        o[i] = c[i] == 1.0f ? v[i] : c[i] == 0.0f ? o[i] : a;
    }
}

// One row of one layer's raw weights: a run of pixels between the same two weight columns,
// whose values on this row are la and lb, as one vector loop.
TEXTOND_VECTOR_KERNEL void interpolate_run(std::size_t count, const float* __restrict ax, float la,
                                           float lb, float* __restrict out) {
    for (std::size_t x = 0; x < count; ++x) out[x] = (1.0f - ax[x]) * la + ax[x] * lb;
}

// The weight image's bilinear lookup (core::placed_tap per axis), y first then x, in float; a
// weight column is read only where a run of the window's pixels lies (the window's cost does not
// grow with the image).
void image_weights(const core::SplatImage& im, int k, const NoiseRequest& q, float* w) {
    const core::Image& src = im.weights;
    const auto n = static_cast<std::size_t>(q.width) * q.height;
    std::vector<int> ix(static_cast<std::size_t>(q.width)), jx(ix.size());
    std::vector<float> ax(ix.size());
    for (int x = 0; x < q.width; ++x) {
        const auto t = core::placed_tap(im.x0, im.scale, src.width, pixel_texel(q.level, q.x0 + x));
        ix[static_cast<std::size_t>(x)] = t.i;
        jx[static_cast<std::size_t>(x)] = t.j;
        ax[static_cast<std::size_t>(x)] = static_cast<float>(t.a);
    }
    for (int y = 0; y < q.height; ++y) {
        const auto t =
            core::placed_tap(im.y0, im.scale, src.height, pixel_texel(q.level, q.y0 + y));
        const auto ay = static_cast<float>(t.a);
        auto column = [&](int l, int col) {
            return (1.0f - ay) * src.at(l, col, t.i) + ay * src.at(l, col, t.j);
        };
        for (int l = 0; l < k; ++l) {
            float* row = w + n * l + static_cast<std::size_t>(y) * q.width;
            for (std::size_t x = 0; x < ix.size();) {
                std::size_t end = x + 1;
                while (end < ix.size() && ix[end] == ix[x] && jx[end] == jx[x]) ++end;
                interpolate_run(end - x, ax.data() + x, column(l, ix[x]), column(l, jx[x]),
                                row + x);
                x = end;
            }
        }
    }
}

// Raw weights of every pixel of `q`'s window, one channel a layer (normalised by the caller).
Result<core::Image> raw_weights(Renderer& r, const PreparedSplat& s, const NoiseRequest& q,
                                Renderer::Work work) {
    const int k = s.layers();
    const auto n = static_cast<std::size_t>(q.width) * q.height;
    core::Image image = take_image(q.width, q.height, k); // every pixel is written
    float* w = image.data.data();
    const core::SplatWeights& sw = s.weights();
    if (sw.kind == core::SplatWeights::Kind::image) {
        image_weights(sw.image, k, q, w);
    } else {
        // Rules: the height field's value (channel 0) and the slope of its normal map.
        NoiseRequest hq = q;
        hq.precision = Precision::f32;
        auto height = r.noise(*s.height(), hq, work);
        if (!height) return height.error();
        const core::SplatRules& rules = sw.rules;
        auto normal_map = r.normals(*s.height(), hq, rules.strength, work);
        if (!normal_map) return normal_map.error();
        constexpr double kDeg = 180.0 / 3.14159265358979323846;
        for (std::size_t i = 0; i < n; ++i) {
            const double h = height.value().plane(0)[i];
            const double nz = 2.0 * normal_map.value().plane(2)[i] - 1.0;
            const double slope = std::acos(std::clamp(nz, -1.0, 1.0)) * kDeg;
            for (int l = 0; l < k; ++l) {
                const core::SplatRule& rule = rules.layers[static_cast<std::size_t>(l)];
                w[l * n + i] =
                    static_cast<float>(core::band_weight(rule.height, rules.height_soft, h) *
                                       core::band_weight(rule.slope, rules.slope_soft, slope));
            }
        }
        recycle_image(std::move(height.value()));
        recycle_image(std::move(normal_map.value()));
    }
    return image;
}

// One window of at most kStripPixels into rows [row0, row0 + q.height) of `out`: the blended
// mean of every pixel and its coefficients (in place of the weights), then each shown layer.
std::optional<Error> splat_window(Renderer& r, const PreparedSplat& s, const NoiseRequest& q,
                                  Renderer::Work work, std::string* used, core::Image& out,
                                  int row0) {
    auto weights = raw_weights(r, s, q, work);
    if (!weights) return weights.error();
    float* cw = weights.value().data.data();
    const int nc = s.channels(), k = s.layers();
    const auto n = static_cast<std::size_t>(q.width) * q.height;
    float mean[core::kMaxSplatLayers][3] = {};
    for (int l = 0; l < k; ++l)
        for (int c = 0; c < nc; ++c) // a grey layer in colour: grey
            mean[l][c] = static_cast<float>(s.layer(l).texton().mean[static_cast<std::size_t>(
                std::min(c, s.layer(l).channels() - 1))]);
    // A grey splat's channels 1 and 2 go to scratch.
    std::vector<float>& scratch = thread_scratch();
    scratch.resize(2 * n);
    float* planes[3] = {scratch.data(), scratch.data() + n, scratch.data()};
    for (int c = 0; c < nc; ++c)
        planes[c] = out.plane(c) + static_cast<std::size_t>(row0) * q.width;
    if (nc == 1) planes[2] = scratch.data() + n;
    blend_setup(k, n, cw, mean, planes);
    for (int l = 0; l < k; ++l) {
        const float* cl = cw + n * l;
        if (std::none_of(cl, cl + n, [](float v) { return v != 0.0f; }))
            continue; // not shown here: not rendered
        const PreparedTexton& layer = s.layer(l);
        NoiseRequest lq = q;
        lq.seed = core::splat_layer_seed(q.seed, l);
        lq.precision = Precision::f32;
        auto img = r.noise(layer, lq, work, used);
        if (!img) return img.error();
        for (int c = 0; c < nc; ++c)
            add_layer(n, cl, img.value().plane(std::min(c, layer.channels() - 1)), mean[l][c],
                      planes[c]);
        recycle_image(std::move(img.value()));
    }
    recycle_image(std::move(weights.value()));
    release_if_large(scratch);
    return std::nullopt;
}

} // namespace

Result<core::Image> Renderer::splat_weights(const PreparedSplat& s, const NoiseRequest& q,
                                            Work work) {
    if (auto err = s.check(q)) return *err;
    auto image = raw_weights(*this, s, q, work);
    if (!image) return image;
    std::vector<float>& sum = thread_scratch();
    sum.resize(image.value().plane_size());
    normalise_planes(s.layers(), image.value().plane_size(), image.value().data.data(), sum.data());
    release_if_large(sum);
    return image;
}

Result<core::Image> Renderer::splat(const PreparedSplat& s, const NoiseRequest& q, Work work,
                                    std::string* used) {
    if (auto err = s.check(q)) return *err;
    core::Image out = take_image(q.width, q.height, s.channels()); // every pixel is written
    const int rows = static_cast<int>(
        std::clamp<std::int64_t>(kStripPixels / std::max(1, q.width), 1, q.height));
    for (int row0 = 0; row0 < q.height; row0 += rows) {
        NoiseRequest strip = q;
        strip.y0 = q.y0 + row0;
        strip.height = std::min(rows, q.height - row0);
        if (auto err = splat_window(*this, s, strip, work, used, out, row0)) return *err;
    }
    return out;
}

} // namespace textond::render
