// Tile archives (server/io/pmtiles, server/io/mbtiles) read back by other code than wrote them:
// PMTiles by the spec-built reader of tests/support, MBTiles by raw SQL.
#include "server/io/image_io.h"
#include "server/io/mbtiles.h"
#include "server/io/pmtiles.h"
#include "tests/support/pmtiles_reader.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>

using namespace textond;
namespace pm = io::pmtiles;
namespace fs = std::filesystem;

namespace {

// Distinct bytes of distinct lengths per tile, so a tile served at another address shows.
std::string payload(int z, std::uint32_t x, std::uint32_t y) {
    return "tile " + std::to_string(z) + "/" + std::to_string(x) + "/" + std::to_string(y) +
           std::string((x * 7 + y * 3 + static_cast<std::uint32_t>(z)) % 11, '#');
}

// Every tile of zooms 0..max_zoom, written in an order other than the tile ids'.
std::vector<pm::Tile> pyramid(int max_zoom) {
    std::vector<pm::Tile> tiles;
    for (int z = max_zoom; z >= 0; --z)
        for (std::uint32_t x = 0; x < (1u << z); ++x)
            for (std::uint32_t y = 0; y < (1u << z); ++y)
                tiles.push_back({z, x, y, static_cast<std::uint32_t>(payload(z, x, y).size())});
    return tiles;
}

test::PmtilesFile write_and_read(const std::vector<pm::Tile>& tiles, const std::string& name) {
    pm::Header h;
    h.tile_type = pm::TileType::webp;
    h.min_zoom = 0;
    h.max_zoom = tiles.front().z;
    h.center_zoom = 3;
    h.min_lon = -180, h.min_lat = -85.0511, h.max_lon = 179.5, h.max_lat = 85.0511;
    h.center_lon = -0.25, h.center_lat = 12.5;
    const std::string path = test::temp_path(name);
    auto w = pm::write_archive(path, h, R"({"name":"test"})", tiles, [&](std::size_t i) {
        return Result<std::string>(payload(tiles[i].z, tiles[i].x, tiles[i].y));
    });
    EXPECT_TRUE(w.ok()) << (w ? "" : w.error().message);
    return test::read_pmtiles(io::read_file(path).value());
}

} // namespace

// spec §4: "Z 0 has tile ID 0, Z 1 begins at 1, Z 2 at 5", and along the Hilbert curve at zoom 1
// (0,0), (0,1), (1,1), (1,0).
TEST(Pmtiles, TileIdsFollowTheSpec) {
    EXPECT_EQ(pm::tile_id(0, 0, 0), 0u);
    EXPECT_EQ(pm::tile_id(1, 0, 0), 1u);
    EXPECT_EQ(pm::tile_id(1, 0, 1), 2u);
    EXPECT_EQ(pm::tile_id(1, 1, 1), 3u);
    EXPECT_EQ(pm::tile_id(1, 1, 0), 4u);
    EXPECT_EQ(pm::tile_id(2, 0, 0), 5u);
    EXPECT_EQ(pm::tile_id(3, 0, 0), 21u);
    // every tile of zooms 0..7 maps onto its zoom's id range, and back through the reader's
    // independent inverse
    for (int z = 0; z <= 7; ++z)
        for (std::uint32_t x = 0; x < (1u << z); ++x)
            for (std::uint32_t y = 0; y < (1u << z); ++y) {
                const std::uint64_t id = pm::tile_id(z, x, y);
                ASSERT_EQ(test::zxy_of_tile_id(id), std::make_tuple(z, x, y)) << id;
            }
    // zoom 24, the native zoom of exports: still a bijection at the corners
    const std::uint32_t last = (1u << 24) - 1;
    for (auto [x, y] : {std::pair{0u, 0u}, {last, 0u}, {0u, last}, {last, last}, {12345u, 999u}})
        EXPECT_EQ(test::zxy_of_tile_id(pm::tile_id(24, x, y)), std::make_tuple(24, x, y));
}

TEST(Pmtiles, ASmallArchiveHasItsHeaderAndEveryTileAtItsAddress) {
    const auto tiles = pyramid(3); // 85 tiles: the root alone
    const test::PmtilesFile f = write_and_read(tiles, "small.pmtiles");
    ASSERT_TRUE(f.ok) << f.error;
    EXPECT_EQ(f.magic, "PMTiles");
    EXPECT_EQ(f.version, 3);
    EXPECT_EQ(f.root_offset, 127u);
    EXPECT_EQ(f.leaf_directories, 0);
    EXPECT_EQ(f.metadata, R"({"name":"test"})");
    EXPECT_EQ(f.addressed_tiles, 85u);
    EXPECT_EQ(f.tile_entries, 85u);
    EXPECT_EQ(f.tile_contents, 85u);
    EXPECT_EQ(f.clustered, 1);
    EXPECT_EQ(f.internal_compression, 1); // none
    EXPECT_EQ(f.tile_compression, 1);
    EXPECT_EQ(f.tile_type, 4); // webp
    EXPECT_EQ(f.min_zoom, 0);
    EXPECT_EQ(f.max_zoom, 3);
    EXPECT_EQ(f.center_zoom, 3);
    EXPECT_EQ(f.min_lon_e7, -1800000000);
    EXPECT_EQ(f.min_lat_e7, -850511000);
    EXPECT_EQ(f.max_lon_e7, 1795000000);
    EXPECT_EQ(f.center_lon_e7, -2500000);
    EXPECT_EQ(f.center_lat_e7, 125000000);
    ASSERT_EQ(f.tiles.size(), tiles.size());
    for (const auto& t : tiles)
        EXPECT_EQ(f.tiles.at({t.z, t.x, t.y}), payload(t.z, t.x, t.y)) << t.z << t.x << t.y;
}

// Zooms 0..8 are 87,381 entries, about 400 kB of directory: leaves, whose index fits in the
// first 16 KiB with the header, as readers fetch only that much first.
TEST(Pmtiles, ALargeArchiveKeepsItsRootInTheFirst16KiBAndItsTilesInLeaves) {
    const auto tiles = pyramid(8);
    const test::PmtilesFile f = write_and_read(tiles, "large.pmtiles");
    ASSERT_TRUE(f.ok) << f.error;
    EXPECT_GT(f.leaf_directories, 1);
    EXPECT_LE(f.root_offset + f.root_length, 16384u);
    EXPECT_EQ(f.data_offset, f.leaves_offset + f.leaves_length);
    ASSERT_EQ(f.tiles.size(), tiles.size());
    std::size_t wrong = 0;
    for (const auto& t : tiles) wrong += f.tiles.at({t.z, t.x, t.y}) != payload(t.z, t.x, t.y);
    EXPECT_EQ(wrong, 0u);
}

TEST(Pmtiles, RefusesATileOffItsZoomsGridAndLeavesNoFileBehind) {
    const std::string dir = test::temp_path("pm-refused");
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::vector<pm::Tile> tiles = {{2, 4, 0, 3}};
    auto w = pm::write_archive(dir + "/a.pmtiles", {}, "{}", tiles,
                               [](std::size_t) { return Result<std::string>(std::string("abc")); });
    EXPECT_FALSE(w.ok());
    EXPECT_TRUE(fs::is_empty(dir));
    // a tile whose bytes fail to come: no archive, no temporary
    const std::vector<pm::Tile> one = {{0, 0, 0, 3}};
    w = pm::write_archive(dir + "/b.pmtiles", {}, "{}", one, [](std::size_t) {
        return Result<std::string>(make_error(ErrorCode::io, "disk gone"));
    });
    ASSERT_FALSE(w.ok());
    EXPECT_EQ(w.error().message, "disk gone");
    EXPECT_TRUE(fs::is_empty(dir));
}

// MBTiles 1.3: rows count from the bottom (TMS), metadata is name/value text.
TEST(Mbtiles, StoresXyzTilesInTmsRowsWithTheSpecsSchema) {
    const std::string path = test::temp_path("flip.mbtiles");
    fs::remove(path);
    {
        auto m = io::Mbtiles::create(path);
        ASSERT_TRUE(m.ok()) << m.error().message;
        ASSERT_TRUE(m.value()->begin().ok());
        ASSERT_TRUE(m.value()->put(3, 1, 2, "a").ok());
        ASSERT_TRUE(m.value()->put(3, 1, 2, "b").ok()); // replaces
        ASSERT_TRUE(m.value()->put(0, 0, 0, "root").ok());
        ASSERT_TRUE(m.value()->commit().ok());
        ASSERT_TRUE(m.value()->set_metadata("format", "png").ok());
        EXPECT_EQ(m.value()->metadata("format").value(), "png");
        EXPECT_EQ(m.value()->metadata("absent").error().code, ErrorCode::not_found);
        EXPECT_EQ(m.value()->get(3, 1, 2).value(), "b");
        EXPECT_EQ(m.value()->get(3, 1, 5).error().code, ErrorCode::not_found);
        auto keys = m.value()->keys();
        ASSERT_TRUE(keys.ok());
        ASSERT_EQ(keys.value().size(), 2u);
        EXPECT_EQ(keys.value()[1].y, 2u);
        EXPECT_EQ(keys.value()[1].length, 1u);
        ASSERT_TRUE(m.value()->close().ok());
    }
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
    sqlite3_stmt* s = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db,
                                 "SELECT tile_row, tile_data FROM tiles WHERE zoom_level = 3 AND "
                                 "tile_column = 1",
                                 -1, &s, nullptr),
              SQLITE_OK);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(s, 0), 5); // 2^3 - 1 - 2
    EXPECT_EQ(std::string(static_cast<const char*>(sqlite3_column_blob(s, 1)), 1), "b");
    EXPECT_EQ(sqlite3_step(s), SQLITE_DONE);
    sqlite3_finalize(s);
    ASSERT_EQ(
        sqlite3_prepare_v2(db, "SELECT value FROM metadata WHERE name = 'format'", -1, &s, nullptr),
        SQLITE_OK);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(sqlite3_column_text(s, 0))), "png");
    sqlite3_finalize(s);
    sqlite3_close(db);
}

TEST(Mbtiles, AFileThatIsNotSqliteIsRefusedInWords) {
    const std::string path = test::temp_path("not.mbtiles");
    std::ofstream(path) << "this is not a database, just words long enough to be read as one";
    auto made = io::Mbtiles::create(path);
    ASSERT_FALSE(made.ok());
    EXPECT_EQ(made.error().code, ErrorCode::unprocessable);
    EXPECT_EQ(made.error().message.rfind(path + ": ", 0), 0u) << made.error().message;
    EXPECT_NE(made.error().message.find("file is not a database"), std::string::npos);
    auto opened = io::Mbtiles::open(path);
    ASSERT_TRUE(opened.ok()); // SQLite reads lazily: the first query tells
    EXPECT_EQ(opened.value()->metadata("name").error().code, ErrorCode::unprocessable);
}
