#include "server/app/engine_kit.h"

#include "api/requests.h"
#include "core/grid_poisson.h"
#include "core/material_set.h"
#include "render/embedded_sources.h"
#include "render/noise_request.h"
#include "render/prepared_texton.h"
#include "server/io/image_io.h"
#include "server/io/tar_archive.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace textond::app {

namespace {

const char* kReadme = R"(# textond engine kit: texton %ID%

Texton noise (the "Texton Noise" paper, Computer Graphics Forum 2017: a sparse convolution of a
small bilinear texton over a Poisson process) of one texton, ready to evaluate on your own GPU
with no server round trip. What the server's tiles
show is what this shader computes: same seed, same position, same colour (to float rounding).

| file | what |
|---|---|
| `textond_kit.json` | every parameter: r, order, mean, MNI, cell size a, lambda, scale, the Poisson threshold table, the seed rule |
| `texton.exr` | the coefficients alpha, float32, r x r (Y or R,G,B): what the shader samples |
| `texton16.png` | (one texton; a material set has `maps/NAME16.png`) the same as 16-bit PNG for engines without EXR: alpha = offset + scale * v / 65535 (`png16_decode` in the JSON; quantised to 2^-16 of the range, so not bit-exact) |
| `glsl/noise_lib.glsl`, `glsl/texton_eval.glsl` | the exact GLSL the server's OpenGL backends run (GLSL 4.50): the hash, the point process and the evaluation of one pixel |
| `glsl/texton_noise.frag`, `glsl/fullscreen.vert` | a fragment entry point over them (a full-screen pass); `glsl/texton_noise.comp` is the server's batched compute one (for reference: it reads each window's uniforms from a storage buffer of records) |
| `hlsl/texton_noise.hlsl` | its HLSL (SM 5) translation, same uniforms (arrays packed by four) |
| `glsl/marginals.glsl`, `marginals.exr` | the exemplar's colour marginals (`marginals=exemplar` on the server), when the texton keeps them: the GLSL that maps the noise onto them and its tables, R32F, 256 x 75 (row 3 k + i: direction i at level k, 0..24) |
| `NOISE_SPEC.md` | the function itself, step by step, with every rounding fixed |

## Use (GLSL)

Compile `#version 450 core` + `noise_lib.glsl` + `texton_eval.glsl` + `texton_noise.frag` as one
fragment shader. (`texton_noise.comp`, the server's compute entry point, is shipped for
reference: it is compiled with `TEXTOND_BATCH` and reads the same values from a buffer of
per-window records instead of uniforms; see its header.)
Upload the table once: an `RGB32F` texture of side `r + 2 pad` (`table_pad` in the JSON: 1, or 3
for order 3), zeros except texel `(x + pad, y + pad)` = alpha(x, y) from `texton.exr` (row 0 =
the file's first row), `GL_NEAREST`; the shader reads it with `texelFetch` only.

To draw the level-0 window of texels `[X0, X0 + w) x [Y0, Y0 + h)` (X0, Y0 signed 64-bit, as in
the tile URLs: tile (x, y) of size 256 at level 0 starts at X0 = 256 x):

```c
int reach = order == 3 ? 1 : 0;
int64_t bcx = floor_div(X0 - r - reach, a), bcy = floor_div(Y0 - r - reach, a); /* base cell */
glUniform1i(u_mode, 0);  glUniform1i(u_level, 0);  glUniform1i(u_st, 1);  glUniform1i(u_sub_log2, 0);
glUniform1i(u_L, r);  glUniform1i(u_r, r);  glUniform1i(u_order, order);  glUniform1i(u_a, a);
glUniform2ui(u_seed, (uint32_t)seed, (uint32_t)(seed >> 32));
glUniform2ui(u_base_cx, (uint32_t)bcx, (uint32_t)((uint64_t)bcx >> 32));   /* same for y */
glUniform2i(u_origin, (int)(X0 - bcx * a), (int)(Y0 - bcy * a));
glUniform2i(u_offset, 0, 0);             /* pixel (i, j) of the viewport is texel (X0 + i, Y0 + j) */
glUniform2i(u_period, 0, 0);  glUniform2i(u_base_mod, 0, 0);
glUniform1f(u_scale, scale);  glUniform3f(u_mean, m0, m1, m2);   /* grey: m0, m0, m0 */
glUniform1uiv(u_thresholds, n, thresholds);  glUniform1i(u_nthresholds, n);
glUniform1i(u_mix, 0);  /* the shader also draws the server's texture mixes: off here, but its */
glUniform1i(u_level_tables, 2);  glUniform1i(u_mask, 3);  /* samplers need units of their own */
```

then draw one full-screen triangle (`fullscreen.vert`, 3 vertices, no buffers). The output is
the field's value (the exemplar's colour values as decoded, before any clamping; the server's PNG
tiles clamp to [0, 1]). In a game, pick the base cell near the camera once per frame and feed each
fragment its texel position relative to it; positions stay exact at any distance because only
the 64-bit base cell is large. Other zoom levels, magnification and tileable mode use the other
uniforms as NOISE_SPEC.md sections 6-7 say; another MNI needs its own threshold table (section 3,
or ask the server: `kit.tar?mni=M`).

## The exemplar's colours (marginals=exemplar)

When `textond_kit.json` has `marginals`: compile `#version 450 core` + `#define
TEXTOND_MARGINALS` + `noise_lib.glsl` + `texton_eval.glsl` + `marginals.glsl` +
`texton_noise.frag`. For level k (0 for magnified levels), upload rows 3k..3k+2 of
`marginals.exr` as an `R32F` texture of 256 x 3 (`GL_NEAREST`, read with `texelFetch`) and set
`u_marg_tables` to its unit, `u_marg_basis` (columns: `marginals.basis`), `u_marg_mean`,
`u_marg_sigma` (`marginals.sigma[k]`) and `u_marg_channels`. The output is the server's
`?marginals=exemplar` tiles (to float rounding).

## Checking it

The server's tile `%BASE%/v1/textons/%ID%/tiles/0/X/Y.exr?seed=S&mni=%MNI%` (256 x 256, float32)
is the window X0 = 256 X, Y0 = 256 Y of the same function: compare it with your render.
)";

void replace_all(std::string& s, const std::string& from, const std::string& to) {
    for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size()))
        s.replace(p, from.size(), to);
}

// The marginal tables of levels 0..24 as one R32F image (row 3 k + i: direction i at level k)
// and their parameters in `params["marginals"]`.
Result<std::string> marginal_tables(const core::Texton& t, nlohmann::json& params) {
    auto prepared = render::PreparedTexton::make(t);
    if (!prepared) return prepared.error();
    constexpr int kLevels = 25, kEntries = core::MarginalTables::kEntries;
    core::Image rows(kEntries, 3 * kLevels, 1);
    nlohmann::json sigma = nlohmann::json::array(), basis = nlohmann::json::array();
    for (int k = 0; k < kLevels; ++k) {
        const auto tables = prepared.value()->marginals(k);
        std::vector<double> s(3, 1.0);
        for (int i = 0; i < tables->channels(); ++i) {
            std::copy_n(tables->table(i), kEntries, &rows.at(0, 0, 3 * k + i));
            s[static_cast<std::size_t>(i)] = tables->sigma(i);
        }
        sigma.push_back(s);
    }
    const core::MarginalModel& m = t.marginals;
    for (int i = 0; i < m.channels; ++i) {
        std::vector<double> column;
        column.reserve(static_cast<std::size_t>(m.channels));
        for (int c = 0; c < m.channels; ++c) column.push_back(m.basis(c, i));
        basis.push_back(column);
    }
    params["marginals"] = {
        {"file", "marginals.exr"},
        {"entries", kEntries},
        {"range_sigmas", core::MarginalTables::kRange},
        {"rows", "3 level + direction, levels 0..24 (magnified levels use level 0)"},
        {"basis", basis},
        {"mean", std::vector<double>(m.mean.begin(), m.mean.begin() + m.channels)},
        {"sigma", sigma}};
    return io::encode_image_memory(rows, io::Encoding::exr);
}

const char* kSetReadme = R"(
## A material set (%MAPS%)

This texton is a material set: its channels are the maps side by side (`maps` in
`textond_kit.json`: each map's name, first channel and channel count), driven by one Poisson
process, so the server's tiles with `map=NAME` are channels of one field. `glsl/material_eval.glsl`
evaluates every map and the height's gradient in one point loop; `glsl/material_noise.frag` writes
them to three colour attachments: channels 0..3, channels 4..7 and the normal map (`n / 2 + 1/2`,
tangent space, +Y up, what `map=normal&strength=S` serves). Compile `#version 450 core` +
`noise_lib.glsl` + `texton_eval.glsl` + `material_eval.glsl` + `material_noise.frag`; for HLSL,
`hlsl/material_noise.hlsl` with `hlsl/texton_noise.hlsl` beside it (it includes it). Set the
texton's uniforms as above (u_mode 0), then:

- `u_set_table0`, `u_set_table1`: two `RGBA32F` textures laid out as `u_table` (side `r + 2 pad`),
  channels 0..3 and 4..7 of `texton.exr` (zeros past the set's channels; `GL_NEAREST`);
- `u_set_channels` (%CHANNELS%), `u_height` (`height_channel`, -1 without a height),
  `u_set_mean0`, `u_set_mean1` (`mean` split by four), `u_strength` (the server's default is 8).

The maps' coefficients are also in `maps/NAME16.png`, 16-bit, with the kit's one `png16_decode`.
The set's shader evaluates the exact levels (level below `limit_level`, where the texton spans
two pixels or more); the server's tiles cover the levels past it.
)";

// 16-bit PNG: one offset and scale for every channel (of every map), so relative values are
// kept: (offset, scale) to decode them.
std::pair<double, double> png16_decode(const core::Image& alpha) {
    float lo = 0.0f, hi = 0.0f;
    if (!alpha.data.empty()) {
        const auto [mn, mx] = std::minmax_element(alpha.data.begin(), alpha.data.end());
        lo = *mn;
        hi = *mx;
    }
    return {double(lo), hi > lo ? double(hi) - lo : 1.0};
}

Result<std::string> png16_bytes(core::Image planes, std::pair<double, double> decode) {
    for (float& v : planes.data) v = static_cast<float>((double(v) - decode.first) / decode.second);
    return io::encode_image_memory(planes, io::Encoding::png16);
}

} // namespace

std::string engine_kit_directory(const std::string& id) {
    return "textond-kit-" + id.substr(0, 12);
}

namespace {

// textond_kit.json: every parameter of the texton's noise at this MNI.
nlohmann::json kit_params(const io::TextonRecord& record, double mni, const std::string& base_url,
                          std::pair<double, double> decode) {
    const core::Texton& t = record.texton;
    const std::string& id = record.meta.id;
    const core::noise::GridPoisson grid(t.size, mni);
    nlohmann::json mean = nlohmann::json::array();
    for (int c = 0; c < t.channels; ++c) mean.push_back(t.mean[static_cast<std::size_t>(c)]);
    return {
        {"id", id},
        {"noise_version", render::kNoiseVersion},
        {"channels", t.channels},
        {"order", t.order},
        {"r", t.size},
        {"mean", mean},
        {"mni", mni},
        {"cell_size", grid.a},
        {"lambda", grid.lambda},
        {"points_per_cell", grid.mu},
        {"scale", static_cast<float>(1.0 / std::sqrt(grid.lambda))},
        {"table_pad", render::table_pad(t.order)},
        {"poisson_thresholds", grid.thresholds},
        {"png16_decode", {{"offset", decode.first}, {"scale", decode.second}}},
        {"rme", record.meta.rme},
        {"seed_rule",
         "any unsigned 64-bit seed; cell (cx, cy) draws from cell_key(seed, cx, cy) "
         "(NOISE_SPEC.md section 2): the kit with seed S equals the server's tiles with ?seed=S"},
        {"tile_template", base_url + "/v1/textons/" + id +
                              "/tiles/{z}/{x}/{y}.exr?seed={seed}&mni=" + api::query_text(mni)}};
}

// A set's maps: their layout in the parameters and each map's coefficients as a 16-bit PNG with
// the kit's one offset and scale.
Result<std::vector<io::TarEntry>> set_entries(const core::Texton& t, const std::string& dir,
                                              nlohmann::json& params, std::string& readme) {
    auto prepared = render::PreparedTexton::make(t);
    if (!prepared) return prepared.error();
    const std::pair<double, double> decode = png16_decode(t.alpha);
    std::vector<io::TarEntry> out = {
        {dir + "glsl/material_eval.glsl", render::embedded::kMaterialEval},
        {dir + "glsl/material_noise.frag", render::embedded::kMaterialNoiseFrag},
        {dir + "hlsl/material_noise.hlsl", render::embedded::kMaterialNoiseHlsl}};
    nlohmann::json maps = nlohmann::json::array();
    std::string names;
    for (const core::TextonMap& m : t.maps) {
        maps.push_back({{"name", m.name},
                        {"first", m.first},
                        {"channels", m.channels},
                        {"file", "maps/" + m.name + "16.png"}});
        names += (names.empty() ? "" : ", ") + m.name;
        auto bytes = png16_bytes(core::channel_planes(t.alpha, m.first, m.channels), decode);
        if (!bytes) return bytes.error();
        out.push_back({dir + "maps/" + m.name + "16.png", std::move(bytes.value())});
    }
    const core::TextonMap* height = core::find_map(t.maps, core::kHeightMap);
    params["maps"] = maps;
    // Order 0 is piecewise constant: no gradient to give.
    params["height_channel"] = height && t.order != 0 ? height->first : -1;
    params["limit_level"] = prepared.value()->limit_level();
    std::string section = kSetReadme;
    replace_all(section, "%MAPS%", names);
    replace_all(section, "%CHANNELS%", std::to_string(t.channels));
    readme += section;
    return out;
}

} // namespace

Result<std::string> engine_kit_tar(const io::TextonRecord& record, const std::string& texton_exr,
                                   double mni, const std::string& base_url) {
    const core::Texton& t = record.texton;
    const std::string& id = record.meta.id;
    const std::pair<double, double> decode = png16_decode(t.alpha);
    nlohmann::json params = kit_params(record, mni, base_url, decode);

    std::string readme = kReadme;
    replace_all(readme, "%ID%", id);
    replace_all(readme, "%BASE%", base_url);
    replace_all(readme, "%MNI%", api::query_text(mni));

    const std::string dir = engine_kit_directory(id) + "/";
    std::vector<io::TarEntry> marginals;
    if (!t.marginals.empty()) {
        auto tables = marginal_tables(t, params);
        if (!tables) return tables.error();
        marginals = {{dir + "glsl/marginals.glsl", render::embedded::kMarginalsGlsl},
                     {dir + "marginals.exr", std::move(tables.value())}};
    }
    if (!t.maps.empty()) { // a set: its maps and its shaders; a PNG holds at most 4 channels
        auto set = set_entries(t, dir, params, readme);
        if (!set) return set.error();
        marginals.insert(marginals.end(), set.value().begin(), set.value().end());
    }
    std::vector<io::TarEntry> all = {{dir + "README.md", readme},
                                     {dir + "textond_kit.json", params.dump(2) + "\n"},
                                     {dir + "texton.exr", texton_exr}};
    if (t.maps.empty()) {
        auto png16 = png16_bytes(t.alpha, decode);
        if (!png16) return png16.error();
        all.push_back({dir + "texton16.png", std::move(png16.value())});
    }
    all.insert(all.end(), {{dir + "glsl/noise_lib.glsl", render::embedded::kNoiseLib},
                           {dir + "glsl/texton_eval.glsl", render::embedded::kTextonEval},
                           {dir + "glsl/texton_noise.frag", render::embedded::kTextonNoiseFrag},
                           {dir + "glsl/texton_noise.comp", render::embedded::kTextonNoiseComp},
                           {dir + "glsl/fullscreen.vert", render::embedded::kFullscreenVert},
                           {dir + "hlsl/texton_noise.hlsl", render::embedded::kTextonNoiseHlsl},
                           {dir + "NOISE_SPEC.md", render::embedded::kNoiseSpec}});
    all.insert(all.end(), marginals.begin(), marginals.end());
    return io::tar_archive(all);
}

} // namespace textond::app
