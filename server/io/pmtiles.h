#pragma once
// PMTiles version 3 (github.com/protomaps/PMTiles, spec/v3/spec.md): one file of tiles that a
// browser reads with HTTP range requests, no tile server. Written here with uncompressed
// directories and metadata, tiles clustered in tile-id order, so any v3 reader can open it.
#include "core/result.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace textond::io::pmtiles {

// spec §3.1 (tile type) and §3.2 (compression)
enum class TileType : std::uint8_t { unknown = 0, mvt = 1, png = 2, jpeg = 3, webp = 4, avif = 5 };
enum class Compression : std::uint8_t { unknown = 0, none = 1, gzip = 2, brotli = 3, zstd = 4 };

inline constexpr int kHeaderBytes = 127;
// spec §2: the header and the root directory lie in the first 16 KiB.
inline constexpr int kRootBytes = 16384 - kHeaderBytes;
inline constexpr int kMaxZoom = 31;

// spec §4 "Tile IDs": the tiles of all lower zooms, then the Hilbert index of (x, y) at z.
std::uint64_t tile_id(int z, std::uint32_t x, std::uint32_t y);

struct Entry {
    std::uint64_t tile_id = 0;
    std::uint64_t offset = 0; // in the tile data (a tile) or the leaf directories (a leaf)
    std::uint32_t length = 0;
    std::uint32_t run_length = 1; // 0: a leaf directory
};

// spec §3.4: entry count, then delta-coded ids, run lengths, lengths and offsets as varints.
std::string serialize_directory(const std::vector<Entry>& entries);

struct Directories {
    std::string root, leaves;
};
// The root alone when it fits in kRootBytes, else leaves of equal entry counts (grown until
// their index fits in the root). `entries` are sorted by tile id.
Directories build_directories(const std::vector<Entry>& entries);

struct Header {
    std::uint64_t root_offset = 0, root_length = 0, metadata_offset = 0, metadata_length = 0,
                  leaves_offset = 0, leaves_length = 0, data_offset = 0, data_length = 0,
                  addressed_tiles = 0, tile_entries = 0, tile_contents = 0;
    bool clustered = true;
    Compression internal_compression = Compression::none;
    Compression tile_compression = Compression::none;
    TileType tile_type = TileType::png;
    int min_zoom = 0, max_zoom = 0, center_zoom = 0;
    // degrees, stored as 1e-7 degree integers
    double min_lon = -180, min_lat = -85, max_lon = 180, max_lat = 85, center_lon = 0,
           center_lat = 0;
};
std::string serialize_header(const Header& h); // spec §3.3: kHeaderBytes, little endian

// One archive to `path`, atomically: header, root directory, metadata (JSON), leaf directories,
// then the tiles in tile-id order. `tiles` may come in any order; `tile_bytes(i)` gives
// tiles[i]'s bytes (of tiles[i].length), asked once each, in tile-id order. The header's layout
// and count fields are filled in here.
struct Tile {
    int z;
    std::uint32_t x, y;
    std::uint32_t length;
};
Result<bool> write_archive(const std::string& path, Header header, const std::string& metadata,
                           const std::vector<Tile>& tiles,
                           const std::function<Result<std::string>(std::size_t)>& tile_bytes);

} // namespace textond::io::pmtiles
