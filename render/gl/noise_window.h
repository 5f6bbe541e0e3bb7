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

// The record's vec4 slots, as texton_noise.comp's load_tile reads them (x, y, z, w).
namespace slot {
inline constexpr int mode = 0;       // mode (1: limit model), level, texels a pixel, -level
inline constexpr int geometry = 1;   // table length L, r, order, cell side a
inline constexpr int seed = 2;       // seed (lo, hi), base cell x (lo, hi)
inline constexpr int base_y = 3;     // base cell y (lo, hi), limit model: x0 - 2 (lo, hi)
inline constexpr int thresholds = 4; // limit model: y0 - 2 (lo, hi); thresholds count, first
inline constexpr int period = 5;     // period (cells), base cell mod period
inline constexpr int origin = 6;     // window origin from the base cell, piece offset
inline constexpr int size = 7;       // piece size, output base, channels
inline constexpr int table = 8;      // table side, first texel, listed points, first cell start
inline constexpr int cells = 9;      // listed cells (x, y), first point, mix
inline constexpr int mean = 10;      // mean colour, 1 / sqrt(lambda)
inline constexpr int kappa = 11;     // limit model: 25 weights over 7 slots (11..17)
inline constexpr int colour = 18;    // limit model: the colour matrix's rows (18..20)
inline constexpr int field = 21;     // mix: field kind, ramp gradient and offset
inline constexpr int mask = 22;      // mix: mask 1 / scale, its origin, level count
inline constexpr int mean_u = 23;    // mix: the first level's mean
inline constexpr int mean_v = 24;    // mix: the last level's mean
} // namespace slot

// Word indices of the fields the batch fills in (the rest is fixed by the window).
namespace field {
inline constexpr int thr_base = slot::thresholds * 4 + 3;
inline constexpr int offset_x = slot::origin * 4 + 2, offset_y = slot::origin * 4 + 3;
inline constexpr int size_x = slot::size * 4, size_y = slot::size * 4 + 1;
inline constexpr int out_base = slot::size * 4 + 2;
inline constexpr int table_base = slot::table * 4 + 1, cell_base = slot::table * 4 + 3;
inline constexpr int point_base = slot::cells * 4 + 2;
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
    bool bytes = false; // read back into core::Image::bytes (NoiseRequest::bytes, at 8 bits)
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
