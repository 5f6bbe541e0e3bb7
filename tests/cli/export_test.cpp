// `textond export` end to end: archives whose tiles are the windows `textond render` draws at the
// same place and level, MBTiles rows counted from the bottom, PMTiles read back by the spec-built
// reader, a killed export resumed into the same bytes, and bad options refused in words.
#include "api/noise_fields.h"
#include "server/io/image_io.h"
#include "tests/support/pmtiles_reader.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sqlite3.h>

#include <cstdlib>
#include <filesystem>

using namespace textond;
namespace fs = std::filesystem;

namespace {

// One texton for every test of this file (an analysis is the slow part).
const std::string& sand_texton() {
    static const std::string path = [] {
        const std::string p = test::temp_path("export-sand.exr");
        const test::RunResult r =
            test::run("analyze " + test::exemplar_path("etr_sand01.png") + " -o " + p);
        EXPECT_EQ(r.code, 0) << r.err;
        return p;
    }();
    return path;
}

// The window `textond render` draws at level `level`, origin (x0, y0), 256 x 256.
core::Image rendered(int level, std::int64_t x0, std::int64_t y0, const std::string& extra = "") {
    const std::string out = test::temp_path("export-window.png");
    const test::RunResult r =
        test::run("render " + sand_texton() + " --backend cpu --lod " + std::to_string(level) +
                  " --x " + std::to_string(x0) + " --y " + std::to_string(y0) +
                  " --w 256 --h 256 " + extra + " -o " + out);
    EXPECT_EQ(r.code, 0) << r.err;
    return io::decode_image_file(out).value();
}

core::Image decoded(const std::string& bytes) {
    auto image = io::decode_image_memory(bytes);
    EXPECT_TRUE(image.ok());
    return image ? image.value() : core::Image();
}

// tile_data of one MBTiles row, by raw SQL.
std::string mbtiles_row(const std::string& path, int z, std::int64_t column, std::int64_t row) {
    sqlite3* db = nullptr;
    sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db,
                       "SELECT tile_data FROM tiles WHERE zoom_level = ? AND tile_column = ? AND "
                       "tile_row = ?",
                       -1, &s, nullptr);
    sqlite3_bind_int(s, 1, z);
    sqlite3_bind_int64(s, 2, column);
    sqlite3_bind_int64(s, 3, row);
    std::string out;
    if (sqlite3_step(s) == SQLITE_ROW)
        out.assign(static_cast<const char*>(sqlite3_column_blob(s, 0)),
                   static_cast<std::size_t>(sqlite3_column_bytes(s, 0)));
    sqlite3_finalize(s);
    sqlite3_close(db);
    return out;
}

std::string sql_text(const std::string& path, const std::string& query) {
    sqlite3* db = nullptr;
    sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db, query.c_str(), -1, &s, nullptr);
    std::string out;
    while (sqlite3_step(s) == SQLITE_ROW) {
        const auto* t = sqlite3_column_text(s, 0);
        out += std::string(t ? reinterpret_cast<const char*>(t) : "") + "\n";
    }
    sqlite3_finalize(s);
    sqlite3_close(db);
    return out;
}

} // namespace

// Box [256, 1024) x [0, 512) texels at zooms 22..24: at 24 (level 0) tiles x 1..3, y 0..1; at 23
// (level 1, 512 texels a tile) x 0..1, y 0; at 22 one tile. Nine in all.
TEST(Export, MbtilesHoldsTheRenderedWindowsInTmsRowsWithTheSpecsMetadata) {
    const std::string out = test::temp_path("box.mbtiles");
    fs::remove(out);
    const test::RunResult r = test::run("export " + sand_texton() +
                                        " --zooms 22-24 --bbox 256,0,1024,512 --seed 7 --backend "
                                        "cpu --jobs 2 -o " +
                                        out);
    ASSERT_EQ(r.code, 0) << r.err;
    const auto summary = nlohmann::json::parse(r.out);
    EXPECT_EQ(summary["tiles"], 9);
    EXPECT_FALSE(fs::exists(out + ".partial"));
    EXPECT_EQ(sql_text(out, "SELECT zoom_level || ':' || count(*) FROM tiles GROUP BY zoom_level"),
              "22:1\n23:2\n24:6\n");
    EXPECT_EQ(sql_text(out, "SELECT value FROM metadata WHERE name IN ('format', 'minzoom', "
                            "'maxzoom', 'type') ORDER BY name"),
              "png\n24\n22\nbaselayer\n");
    const std::string bounds = sql_text(out, "SELECT value FROM metadata WHERE name = 'bounds'");
    EXPECT_EQ(std::count(bounds.begin(), bounds.end(), ','), 3) << bounds;
    // zoom 24, x 2, y 1: row 2^24 - 1 - 1; its pixels are render's at level 0, (512, 256)
    const std::string tile = mbtiles_row(out, 24, 2, (1 << 24) - 2);
    ASSERT_FALSE(tile.empty());
    EXPECT_EQ(test::max_abs_diff(decoded(tile), rendered(0, 512, 256, "--seed 7")), 0.0);
    // zoom 23, x 1, y 0: level 1, origin (256, 0) in that level's pixels
    const std::string coarse = mbtiles_row(out, 23, 1, (1 << 23) - 1);
    ASSERT_FALSE(coarse.empty());
    EXPECT_EQ(test::max_abs_diff(decoded(coarse), rendered(1, 256, 0, "--seed 7")), 0.0);
    // not the unflipped row
    EXPECT_TRUE(mbtiles_row(out, 24, 2, 1).empty());
}

// Killed right after its first committed batch (the crash point ends it like kill -9), the export
// resumes from OUT.partial and writes the bytes an uninterrupted export writes.
TEST(Export, PmtilesResumesAfterAKillIntoTheSameBytesAndReadsBack) {
    const std::string args = " --zooms 23-24 --bbox 0,0,5120,3840 --backend cpu --quiet ";
    const std::string once = test::temp_path("once.pmtiles"),
                      resumed = test::temp_path("r.pmtiles");
    for (const auto& p : {once, resumed, resumed + ".partial"}) fs::remove(p);
    test::RunResult r = test::run("export " + sand_texton() + args + "-o " + once);
    ASSERT_EQ(r.code, 0) << r.err;

    ::setenv("TEXTOND_CRASH_POINT", "export-committed", 1);
    r = test::run("export " + sand_texton() + args + "--jobs 1 -o " + resumed);
    ::unsetenv("TEXTOND_CRASH_POINT");
    ASSERT_EQ(r.code, 86) << r.err;
    EXPECT_FALSE(fs::exists(resumed));
    ASSERT_TRUE(fs::exists(resumed + ".partial"));
    r = test::run("export " + sand_texton() + args + "-o " + resumed);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("resuming: "), std::string::npos) << r.err;
    const auto summary = nlohmann::json::parse(r.out);
    EXPECT_GT(summary["resumed_with"].get<int>(), 0);
    EXPECT_LT(summary["resumed_with"].get<int>(), 380);
    EXPECT_FALSE(fs::exists(resumed + ".partial"));
    const std::string bytes = io::read_file(resumed).value();
    EXPECT_TRUE(bytes == io::read_file(once).value());

    const test::PmtilesFile f = test::read_pmtiles(bytes);
    ASSERT_TRUE(f.ok) << f.error;
    EXPECT_EQ(f.tiles.size(), 380u); // 20 x 15 at zoom 24, 10 x 8 at zoom 23
    EXPECT_EQ(f.tile_type, 2);       // png
    EXPECT_EQ(f.min_zoom, 23);
    EXPECT_EQ(f.max_zoom, 24);
    EXPECT_EQ(nlohmann::json::parse(f.metadata)["format"], "png");
    EXPECT_EQ(f.min_lon_e7, -1800000000); // x = 0 is the west edge of the world
    EXPECT_EQ(f.max_lat_e7, 850511288);   // y = 0 the north edge, 85.0511288 degrees
    const auto at = f.tiles.find({24, 19, 14});
    ASSERT_NE(at, f.tiles.end());
    EXPECT_EQ(test::max_abs_diff(decoded(at->second), rendered(0, 19 * 256, 14 * 256)), 0.0);
}

TEST(Export, RefusesBadOptionsInWordsAndAPartialOfOtherOptions) {
    const std::string out = test::temp_path("bad.pmtiles");
    test::temp_path("bad.pmtiles.partial-journal"); // SQLite's, beside the partial: removed too
    const struct {
        std::string args, words;
    } cases[] = {
        {"--zooms 22-25 --bbox 0,0,256,256", "--zooms"},
        {"--zooms 24 --bbox -256,0,256,256", "--bbox"},
        {"--zooms 24 --bbox 0,0,256", "--bbox"},
        {"--zooms 0 --bbox 0,0,9999999999,1", "--bbox"},
        {"--zooms 24 --bbox 0,0,256,256 --format zip", "--format"},
        {"--zooms 24 --bbox 0,0,256,256 --tile-format exr", "--tile-format"},
        {"--zooms 24 --bbox 0,0,256,256 --map lit", "map=lit"},
        {"--zooms 24 --bbox 0,0,256,256 --mni 0", "mni"},
        {"--zooms 24 --bbox 0,0,4294967296,4294967296", "more than"},
        {"--zooms 24 --bbox 0,0,256,256,", "--bbox"},
        {"--zooms 24", "needs --bbox"},
        {"--bbox 0,0,256,256", "needs --zooms"},
        // each option once, as a URL names each field once
        {"--zooms 24 --bbox 0,0,256,256 --seed 1 --seed 2", "given twice"},
        {"--zooms 24 --bbox 0,0,256,256 --encoding terrarium --encoding mapbox", "given twice"},
    };
    for (const auto& c : cases) {
        const test::RunResult r =
            test::run("export " + sand_texton() + " " + c.args + " -o " + out);
        EXPECT_EQ(r.code, 2) << c.args;
        EXPECT_NE(r.err.find(c.words), std::string::npos) << c.args << ": " << r.err;
        EXPECT_FALSE(fs::exists(out)) << c.args;
        EXPECT_FALSE(fs::exists(out + ".partial")) << c.args;
    }
    // a partial of another seed is neither resumed nor overwritten
    ::setenv("TEXTOND_CRASH_POINT", "export-committed", 1);
    test::RunResult r = test::run("export " + sand_texton() +
                                  " --zooms 24 --bbox 0,0,5120,5120 --quiet --jobs 1 -o " + out);
    ::unsetenv("TEXTOND_CRASH_POINT");
    ASSERT_EQ(r.code, 86) << r.err;
    r = test::run("export " + sand_texton() + " --zooms 24 --bbox 0,0,5120,5120 --seed 2 -o " +
                  out);
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("other options"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::exists(out + ".partial"));
    fs::remove(out + ".partial");

    // -o in a directory that is not there: said before any work
    r = test::run("export " + sand_texton() + " --zooms 24 --bbox 0,0,256,256 -o " +
                  test::temp_path("no-such-dir") + "/a.pmtiles");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("no directory"), std::string::npos) << r.err;
}

// The export takes every noise field a tile URL takes (api/noise_fields.h), as --NAME, reads it
// with the tile parser (a bad value is refused naming the field) and lists it in its help.
TEST(Export, TakesEveryNoiseFieldOfATileUrl) {
    const std::string help = test::run("export --help").out;
    const std::string out = test::temp_path("fields.pmtiles");
    for (const std::string& name : api::noise_field_names(api::kTileRoute)) {
        EXPECT_NE(help.find("--" + name + " "), std::string::npos) << name;
        const test::RunResult r =
            test::run("export " + sand_texton() + " --zooms 24 --bbox 0,0,256,256 --" + name +
                      " x! -o " + out);
        EXPECT_EQ(r.code, 2) << name;
        EXPECT_EQ(r.err.find("unknown"), std::string::npos) << name << ": " << r.err;
        EXPECT_NE(r.err.find(name), std::string::npos) << name << ": " << r.err;
        EXPECT_FALSE(fs::exists(out)) << name;
    }
}

// Someone else's SQLite file where the partial would be is neither taken over nor changed (nor
// deleted once the archive is written).
TEST(Export, AForeignFileAtThePartialsPlaceIsLeftAlone) {
    const std::string out = test::temp_path("foreign.pmtiles"), partial = out + ".partial";
    fs::remove(out);
    fs::remove(partial);
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(partial.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE precious (a); INSERT INTO precious VALUES (42);",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
    const std::string before = io::read_file(partial).value();
    const test::RunResult r =
        test::run("export " + sand_texton() + " --zooms 24 --bbox 0,0,256,256 -o " + out);
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("is not a partial textond export"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_TRUE(io::read_file(partial).value() == before);
    fs::remove(partial);
}

// A link at the partial's place, even one to a path that does not exist yet, is refused: the
// database would be written at its target, outside the output's directory, and OUT become it.
TEST(Export, ALinkAtThePartialsPlaceIsRefused) {
    const std::string out = test::temp_path("linked.pmtiles"), partial = out + ".partial";
    const std::string target = test::temp_path("elsewhere.db");
    fs::remove(out);
    fs::remove(partial);
    fs::remove(target);
    fs::create_symlink(target, partial);
    const test::RunResult r =
        test::run("export " + sand_texton() + " --zooms 24 --bbox 0,0,256,256 -o " + out);
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("not a regular file"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(target)) << "written through the link";
    EXPECT_FALSE(fs::exists(out));
    EXPECT_TRUE(fs::is_symlink(partial));
    fs::remove(partial);
}
