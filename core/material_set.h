#pragma once
// Material sets: albedo, height, roughness, ... of one surface, modelled by one texton whose
// channels are the maps side by side. One Gaussian model over all C channels (SOT paper section
// 3.1 with C channels), one phase for all of them (texton-noise section 4.3, which holds for any
// channel count) and a C x C colour correction, so one Poisson process keeps the cross-covariance
// between maps as it keeps the one between R, G and B.
#include "core/gaussian_model.h"
#include "core/image.h"
#include "core/result.h"
#include "core/texton_analysis.h"

#include <optional>
#include <string>
#include <vector>

namespace textond::core {

// The maps a set may hold, in their channel order: albedo (RGB) and the grey maps.
inline constexpr const char* kMapNames[] = {"albedo", "height", "roughness", "ao", "metallic"};
inline constexpr const char* kHeightMap = "height";
inline constexpr const char* kNormalMap = "normal"; // made from the height (render/normal_map.h)
// The albedo lit through the normal map by one directional light (render/normal_map.h).
inline constexpr const char* kLitMap = "lit";
// Where that light comes from by default: the upper left (azimuth counter-clockwise from +x,
// +y up), 45 degrees above the surface.
inline constexpr double kDefaultLightAzimuth = 135.0;
inline constexpr double kDefaultLightElevation = 45.0;
// The texels a height step of 1 spans in a normal map (its steepness), default and bound.
inline constexpr double kDefaultNormalStrength = 8.0;
inline constexpr double kMaxNormalStrength = 1000.0;

// Why `maps` cannot lay out `channels` channels (names known and unique, contiguous from 0,
// 1..kMaxChannels in all, albedo 1 or 3 channels, the others 1), or nothing.
std::optional<Error> validate_maps(const std::vector<TextonMap>& maps, int channels);

// The map called `name`, or null.
const TextonMap* find_map(const std::vector<TextonMap>& maps, const std::string& name);

// Channels [first, first + count) of an image, or of a model (its mean, kernel, spectra and the
// covariance's block): a map's own model, whose RME the set reports per map.
Image channel_planes(const Image& u, int first, int count);
GaussianModel channel_subset(const GaussianModel& m, int first, int count);

struct SetAnalysis {
    AnalysisResult result;       // of all channels (result.rme: the set's overall RME)
    std::vector<double> map_rme; // per map, of its channels of the corrected texton
};

// `stacked`: the maps' pixels side by side (same size), laid out by `maps`. The verdict
// (micro/macro) is the first map's; marginals are not kept for sets.
Result<SetAnalysis> analyze_material_set(const Image& stacked, const std::vector<TextonMap>& maps,
                                         const AnalysisParams& params,
                                         const ProgressFn& progress = {});

} // namespace textond::core
