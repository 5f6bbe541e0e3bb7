#pragma once
// One window of texton noise as the batched compute shader reads it (glsl/texton_noise.comp,
// load_tile): its record of parameters, its Poisson thresholds, and at exact levels up to 1 the
// window's points listed once in the global order. Made on the caller's thread with no GL, so
// many requests prepare at once and the GL context is held only to upload and dispatch.
#include "core/result.h"
#include "render/noise_request.h"
#include "render/prepared_mix.h"
#include "render/prepared_texton.h"

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace textond::render::gl {

inline constexpr int kRecordVec4s = 25; // texton_noise.comp, kRecord
inline constexpr int kRecordWords = 4 * kRecordVec4s;

// Word indices of the fields the batch fills in (the rest is fixed by the window).
namespace field {
inline constexpr int thr_base = 4 * 4 + 3;
inline constexpr int offset_x = 6 * 4 + 2, offset_y = 6 * 4 + 3;
inline constexpr int size_x = 7 * 4 + 0, size_y = 7 * 4 + 1, out_base = 7 * 4 + 2;
inline constexpr int table_base = 8 * 4 + 1, cell_base = 8 * 4 + 3;
inline constexpr int point_base = 9 * 4 + 2;
} // namespace field

struct NoiseWindow {
    std::array<std::uint32_t, kRecordWords> record{};
    std::vector<std::uint32_t> thresholds;
    // Listed points (exact levels up to 1): each cell's first point (cells by y then x, one past
    // the last at the end) and the points, 4 words each.
    std::vector<std::uint32_t> starts, points;
    std::shared_ptr<const LevelTable> table; // one texton's (null for a mix)
    // A mix: every level's table (vec4 texels, layer after layer) and its mask, if any.
    std::vector<float> mix_tables;
    const core::MixField* mask = nullptr;
    int width = 0, height = 0, channels = 0;
    Precision precision = Precision::f32;
    const Cancel* cancel = nullptr;
    bool limit_model = false;
};

// `mix` null: texton noise of `texton`; else the mix's exact level (its level 0 is `texton`).
// The request is assumed checked (PreparedTexton::check, PreparedMix::check). `host_lists`
// false: the points are never listed here (a GPU's kernel draws them in shared memory).
NoiseWindow make_noise_window(const PreparedTexton& texton, const PreparedMix* mix,
                              const NoiseRequest& q, bool host_lists = true);

// A level table as `components` floats a texel, row by row (G[y][x], zeros past its channels):
// the layout of the RGB32F textures and of the vec4 storage buffers.
void interleave_table(const LevelTable& t, int components, float* out);

} // namespace textond::render::gl
