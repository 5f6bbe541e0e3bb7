#pragma once
// Which tiles `textond export` writes: every web-map tile of zooms A..B (level = 24 - zoom, as
// the /map/{z}/{x}/{y} routes and TileJSON have it) that meets a box of the plane, given in
// texels (pixels of zoom 24, level 0). Archive formats address tiles from 0 to 2^z - 1, so the
// box lies in [0, tile_size * 2^24) on both axes: zoom 0's one tile.
#include "core/result.h"

#include <cstdint>
#include <string>
#include <vector>

namespace textond::cli {

struct TileAddress {
    int z;
    std::uint32_t x, y;
};

struct ExportPlan {
    int min_zoom = 0, max_zoom = 0, tile_size = 256;
    std::int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0; // texels, [x0, x1) x [y0, y1)
    struct Zoom {
        int z;
        std::uint32_t x0, x1, y0, y1; // tile indices, inclusive
        std::uint64_t count() const { return std::uint64_t{x1 - x0 + 1} * (y1 - y0 + 1); }
    };
    std::vector<Zoom> zooms;
    std::uint64_t count() const;
    std::vector<TileAddress> tiles() const; // zoom by zoom, rows top down
    std::int64_t world() const { return std::int64_t{tile_size} << 24; } // texels a side
    // Where the box lies if zoom 0's tile were the Web Mercator world (archive headers and
    // viewers speak degrees): west, south, east, north.
    std::vector<double> bounds_degrees() const;
    // The zoom at which the box's larger side spans about 1024 pixels, within A..B.
    int center_zoom() const;
};

inline constexpr int kExportMaxZoom = 24; // one texel per pixel; archives hold no magnified tiles
inline constexpr std::uint64_t kExportMaxTiles = std::uint64_t{1} << 22;

// "--zooms A-B" (or "A"), "--bbox X0,Y0,X1,Y1" and the tile size; invalid_argument with the
// reason otherwise.
Result<ExportPlan> make_export_plan(const std::string& zooms, const std::string& bbox,
                                    int tile_size);

} // namespace textond::cli
