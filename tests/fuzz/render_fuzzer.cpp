// libFuzzer target over what the request parsers let through to a render: mix fields,
// tile coordinates and noise parameters into a small CPU render of a tiny mix; surface
// parameters and raw points into evaluate_surface; mesh parameters and an OBJ body into the
// view, the cost estimate and the rasteriser. Whatever the parsers accept must render to finite
// pixels or fail with a 4xx-class error, never crash or answer ErrorCode::internal.
#include "api/requests.h"
#include "core/texture_mix.h"
#include "render/cpu_backend.h"
#include "render/prepared_mix.h"
#include "render/surface_eval.h"
#include "server/io/obj_mesh.h"
#include "tests/fuzz/fuzz_query.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace {

using namespace textond;

// A tiny texton (r = 8) with smooth coefficients; `shift` makes the levels of a mix differ.
core::Texton tiny_texton(int order, double shift) {
    core::Texton t;
    t.size = 8;
    t.channels = 3;
    t.order = order;
    t.mean = {0.3 + shift, 0.5, 0.7 - shift};
    t.alpha = core::Image(8, 8, 3);
    for (int c = 0; c < 3; ++c)
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x)
                t.alpha.at(c, x, y) = static_cast<float>(0.02 * std::sin(0.9 * x + 1.7 * y + c) +
                                                         0.01 * shift * std::cos(x - y));
    return t;
}

bool acceptable(const Error& e) {
    return e.code != ErrorCode::internal && e.code != ErrorCode::io &&
           e.code != ErrorCode::cancelled;
}

bool finite(const core::Image& im) {
    return std::all_of(im.data.begin(), im.data.end(), [](float v) { return std::isfinite(v); });
}

void fail() {
    __builtin_trap();
}

void mix_render(api::Query q, std::string_view path, const api::Query& tile_query) {
    // Two valid ids unless the input names its own: the field is what is fuzzed here.
    q.emplace("u", std::string(64, 'a'));
    q.emplace("v", std::string(64, 'b'));
    api::MixRequest m;
    if (api::parse_mix(q, false, m)) return;
    // Tile coordinates from the path ("z/x/y"), as a mix tile route parses them.
    std::vector<std::string_view> p;
    for (std::size_t pos = 0; pos <= path.size() && p.size() < 3;) {
        std::size_t end = path.find('/', pos);
        if (end == std::string_view::npos) end = path.size();
        p.push_back(path.substr(pos, end - pos));
        pos = end + 1;
    }
    while (p.size() < 3) p.push_back("0");
    api::TileRequest t;
    if (api::parse_tile(std::string(64, 'a'), p[0], p[1], p[2], "png", tile_query, t)) return;
    const int levels = std::min(m.levels, 8); // the field and level logic, not R's cost
    std::vector<core::Texton> ts;
    for (int l = 0; l < levels; ++l) ts.push_back(tiny_texton(1, 0.2 * l / std::max(1, levels)));
    auto mix = render::PreparedMix::make(std::move(ts), m.field);
    if (!mix) {
        if (!acceptable(mix.error())) fail();
        return;
    }
    render::NoiseRequest nq;
    nq.seed = t.noise.seed;
    nq.mni = std::min(t.noise.mni, 8.0);
    nq.level = t.level;
    nq.x0 = t.x0();
    nq.y0 = t.y0();
    nq.width = nq.height = 8;
    if (auto err = mix.value()->check(nq)) { // as the server checks before it renders
        if (!acceptable(*err)) fail();
        return;
    }
    render::CpuBackend cpu(1, 16);
    auto image = cpu.render_mix(*mix.value(), nq);
    if (!image) {
        if (!acceptable(image.error())) fail();
        return;
    }
    if (!finite(image.value())) fail();
}

std::vector<float> floats_of(std::string_view bytes, std::size_t max) {
    std::vector<float> v(std::min(max, bytes.size() / sizeof(float)));
    if (!v.empty()) std::memcpy(v.data(), bytes.data(), v.size() * sizeof(float));
    return v;
}

void surface(const api::Query& q, std::string_view raw) {
    api::SurfaceParams p;
    if (api::parse_surface(std::string(64, 'a'), q, false, p)) return;
    std::vector<float> all = floats_of(raw, 96);
    all.resize(all.size() / 6 * 6);
    std::vector<float> points(all.begin(), all.begin() + static_cast<long>(all.size() / 2)),
        normals(all.begin() + static_cast<long>(all.size() / 2), all.end());
    render::SurfaceRequest sr{p.seed, std::min(p.mni, 8.0), p.scale, nullptr};
    static const core::Texton tex = tiny_texton(3, 0.0);
    auto got = render::evaluate_surface(tex, sr, points, normals, 1);
    if (!got) {
        if (!acceptable(got.error())) fail();
        return;
    }
    for (float v : got.value())
        if (!std::isfinite(v)) fail();
}

void mesh(const api::Query& q, std::string_view obj) {
    api::SurfaceParams p;
    if (api::parse_surface(std::string(64, 'a'), q, true, p)) return;
    auto parsed = io::parse_obj(obj);
    if (!parsed) {
        if (!acceptable(parsed.error())) fail();
        return;
    }
    render::Camera cam;
    cam.fov_degrees = p.fov;
    if (p.camera) {
        cam.automatic = false;
        cam.eye = {p.eye[0], p.eye[1], p.eye[2]};
        cam.target = {p.target[0], p.target[1], p.target[2]};
    }
    const int w = std::min(p.width, 24), h = std::min(p.height, 24);
    render::SurfaceRequest sr{p.seed, std::min(p.mni, 4.0), p.scale, nullptr};
    auto view = render::mesh_view(parsed.value(), sr, cam, w, h);
    if (!view) {
        if (!acceptable(view.error())) fail();
        return;
    }
    // The estimate the service admits by bounds the rasteriser's work: every triangle's clamped
    // screen box, so never more than triangles x pixels.
    const std::uint64_t tests = render::mesh_raster_tests(parsed.value(), view.value(), w, h);
    const std::uint64_t nt = parsed.value().triangles.size() / 3;
    if (tests > nt * static_cast<std::uint64_t>(w + 1) * static_cast<std::uint64_t>(h + 1)) fail();
    static const core::Texton tex = tiny_texton(1, 0.0);
    auto image = render::render_mesh_preview(tex, sr, parsed.value(), cam, w, h, 1);
    if (!image) {
        if (!acceptable(image.error())) fail();
        return;
    }
    for (float v : image.value().data)
        if (!(v >= 0.0f && v <= 1.0f)) fail();
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // Layout: selector byte, then "path|query|body": for a mix the query holds the mix's fields
    // and the body the tile's query; else the body is raw floats (surface) or OBJ text (mesh).
    const std::string_view in(reinterpret_cast<const char*>(data), size);
    if (in.empty()) return 0;
    const unsigned selector = static_cast<unsigned char>(in[0]) % 3;
    std::string_view rest = in.substr(1);
    const std::size_t bar1 = rest.find('|');
    const std::string_view path = rest.substr(0, bar1);
    rest = bar1 == std::string_view::npos ? std::string_view() : rest.substr(bar1 + 1);
    const std::size_t bar2 = rest.find('|');
    const api::Query q = test::query_of(rest.substr(0, bar2), false);
    const std::string_view body =
        bar2 == std::string_view::npos ? std::string_view() : rest.substr(bar2 + 1);
    switch (selector) {
    case 0:
        mix_render(q, path, test::query_of(body, false));
        break;
    case 1:
        surface(q, body);
        break;
    default:
        mesh(q, body);
    }
    return 0;
}
