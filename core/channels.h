#pragma once
// How many channels a texton may have: 1 (grey), 3 (RGB) or a material set's maps side by side
// (albedo RGB, height, roughness, ...), at most 8 (core/material_set.h).
#include <array>

namespace textond::core {

inline constexpr int kMaxChannels = 8;

// One value per channel; entries past the texton's channel count are 0.
using ChannelValues = std::array<double, kMaxChannels>;

} // namespace textond::core
