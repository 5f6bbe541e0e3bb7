#pragma once
// Elevation tiles in the two RGB encodings terrain engines read (MapLibre's raster-dem,
// Mapbox's and Tangram's terrain, Cesium's heightmap loaders):
//   terrarium  metres = R * 256 + G + B / 256 - 32768        (step 1/256 m, range +-32768 m)
//   mapbox     metres = -10000 + (R * 65536 + G * 256 + B) * 0.1   (step 0.1 m)
// A material set's height map (0..1) becomes metres as height * height_scale; values beyond an
// encoding's range are clamped to it.
#include "core/image.h"

#include <optional>
#include <string>

namespace textond::core {

enum class ElevationEncoding { terrarium, mapbox };

std::optional<ElevationEncoding> parse_elevation_encoding(const std::string& name);
const char* elevation_encoding_name(ElevationEncoding e);
// The encoding's step in metres: a decoded tile is within half of it of the metres encoded.
double elevation_step(ElevationEncoding e);

// One channel of heights (0..1) as three channels of k / 255 (k = 0..255), which an 8-bit PNG
// encoder stores as the bytes k exactly.
Image encode_elevation(const Image& height, ElevationEncoding e, double height_scale);
// The metres of one encoded pixel (its bytes); the inverse, for tests and clients.
double decode_elevation(int r, int g, int b, ElevationEncoding e);

} // namespace textond::core
