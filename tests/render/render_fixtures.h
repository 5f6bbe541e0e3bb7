#pragma once
// Textons analysed from the shared exemplars, once per test process, ready for the backends.
#include "render/prepared_mix.h"
#include "render/prepared_texton.h"

#include <functional>
#include <memory>
#include <string>

namespace textond::test {

// `name` from shared/data/exemplars, analysed with r = size (order 1, 50 iterations, seed 0).
std::shared_ptr<const render::PreparedTexton> analysed_texton(const std::string& name, int size,
                                                              int order = 1);

// A mix of two shared exemplars (r = size, order 1, 30 iterations, seed 0) with `levels` levels.
std::shared_ptr<const render::PreparedMix> analysed_mix(const std::string& u, const std::string& v,
                                                        int size, int levels,
                                                        const core::MixField& field);

// A material set derived from a shared photo: albedo = etr_pebbles04's RGB, height = its
// luminance (mean of R, G, B: bright pebbles stand up, the dark gaps between them are low); with
// `roughness`, a fifth channel R G (a non-linear map) laid out albedo, roughness, height, so the
// height is channel 4. Analysed with r = size and `order` (50 iterations, seed 0).
std::shared_ptr<const render::PreparedTexton> pebble_set(int size, int order,
                                                         bool roughness = false);

// One function, many windows: `q` rendered whole and as its four quarter tiles (even sides).
// Returns -1 when every tile equals its part of the whole bit for bit, else the first tile (0-3)
// that does not, or -2 when a render fails.
using RenderFn = std::function<Result<core::Image>(const render::NoiseRequest&)>;
int first_tile_off_the_region(const RenderFn& render, const render::NoiseRequest& q);

// Standard deviation of channel c of the level-0 field: sqrt(C(0)_cc).
double field_std(const render::PreparedTexton& t, int c);

} // namespace textond::test
