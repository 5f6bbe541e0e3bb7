#pragma once
#include "core/channels.h"
#include "core/image.h"
#include "core/marginals.h"

#include <array>
#include <string>
#include <vector>

namespace textond::core {

// One map of a material set: channels [first, first + channels) of its texton.
struct TextonMap {
    std::string name;
    int first = 0;
    int channels = 1; // 3 for albedo, 1 for the grey maps
};

// Texton interpolation coefficients (texton-noise paper, section 4, eq. (3)):
// h(y) = sum_k alpha(k) psi_order(y - k), with alpha supported on [0, size)^2.
struct Texton {
    int size = 0;     // r
    int channels = 0; // 1, 3, or a material set's maps side by side (at most kMaxChannels)
    int order = 1;    // 0 nearest (discrete SOT), 1 bilinear, 3 cubic B-spline
    ChannelValues mean{};
    Image alpha; // size x size x channels
    // The exemplar's colour marginals, for restoring them on request (core/marginals.h); empty
    // for textons without an exemplar (mixes) or analysed before they were kept.
    MarginalModel marginals;
    // A material set's maps (core/material_set.h), side by side in the channels; empty for a
    // texton of one exemplar.
    std::vector<TextonMap> maps;
};

} // namespace textond::core
