#pragma once
// A PMTiles v3 reader for the tests, written from the spec apart from server/io/pmtiles: it walks
// every directory (root and leaves) and names each tile by converting its id back to z/x/y with
// the spec's inverse Hilbert curve, so a writer bug is not mirrored by the reader.
#include <cstdint>
#include <map>
#include <string>
#include <tuple>

namespace textond::test {

struct PmtilesFile {
    std::string magic;
    int version = 0;
    std::uint64_t root_offset = 0, root_length = 0, metadata_offset = 0, metadata_length = 0,
                  leaves_offset = 0, leaves_length = 0, data_offset = 0, data_length = 0,
                  addressed_tiles = 0, tile_entries = 0, tile_contents = 0;
    int clustered = 0, internal_compression = 0, tile_compression = 0, tile_type = 0;
    int min_zoom = 0, max_zoom = 0, center_zoom = 0;
    std::int32_t min_lon_e7 = 0, min_lat_e7 = 0, max_lon_e7 = 0, max_lat_e7 = 0, center_lon_e7 = 0,
                 center_lat_e7 = 0;
    std::string metadata;
    std::map<std::tuple<int, std::uint32_t, std::uint32_t>, std::string> tiles; // (z, x, y)
    int leaf_directories = 0;
    bool ok = false;
    std::string error; // why not ok
};

PmtilesFile read_pmtiles(const std::string& bytes);
// The spec's inverse: tile id -> (z, x, y).
std::tuple<int, std::uint32_t, std::uint32_t> zxy_of_tile_id(std::uint64_t id);

} // namespace textond::test
