// The request parsers of api/ as tables, without HTTP: each row is one request and the error
// code it must give ("" = accepted). Bounds are tested on both sides (the last accepted value
// and the first refused one), so moving any limit by one step fails a row. The HTTP table in
// tests/server/bad_requests_test.cpp stays the end-to-end check.
#include "api/json_body.h"
#include "api/noise_fields.h"
#include "api/query_text.h"
#include "api/requests.h"
#include "core/grid_poisson.h"
#include "core/noise_levels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace textond::api {
namespace {

const std::string kId(64, 'a');

struct Row {
    std::string what;
    std::function<std::optional<ApiError>()> parse;
    std::string code; // "" when the request is valid
};

void check(const std::vector<Row>& rows) {
    for (const Row& r : rows) {
        SCOPED_TRACE(r.what);
        const std::optional<ApiError> e = r.parse();
        if (r.code.empty()) {
            EXPECT_FALSE(e) << e->code << ": " << e->message;
            continue;
        }
        ASSERT_TRUE(e) << "accepted, expected " << r.code;
        EXPECT_EQ(e->code, r.code) << e->message;
        EXPECT_FALSE(e->message.empty());
    }
}

Row tile(std::string what, std::string z, std::string x, std::string y, std::string ext, Query q,
         std::string code) {
    return {std::move(what),
            [=] {
                TileRequest t;
                return parse_tile(kId, z, x, y, ext, q, t);
            },
            std::move(code)};
}

TEST(Requests, TileTable) {
    const std::string big = std::to_string((std::int64_t{1} << 62) / 256 - 1); // last tile at z 0
    const std::string over = std::to_string((std::int64_t{1} << 62) / 256);
    const std::string low = std::to_string(-(std::int64_t{1} << 62) / 256); // starts at -2^62
    const std::string below = std::to_string(-(std::int64_t{1} << 62) / 256 - 1);
    check({
        tile("plain", "0", "0", "0", "png", {}, ""),
        tile("negative indices", "3", "-17", "-4", "exr", {}, ""),
        tile("png16", "0", "1", "1", "png16", {}, ""),
        tile("jpeg is not a format", "0", "0", "0", "jpg", {}, "invalid_format"),
        tile("finest level", std::to_string(core::noise::kMinLevel), "0", "0", "png", {}, ""),
        tile("past the finest level", std::to_string(core::noise::kMinLevel - 1), "0", "0", "png",
             {}, "level_out_of_range"),
        tile("coarsest level", std::to_string(core::noise::kMaxLevel), "0", "0", "png", {}, ""),
        tile("past the coarsest level", std::to_string(core::noise::kMaxLevel + 1), "0", "0", "png",
             {}, "level_out_of_range"),
        tile("level is not a number", "x", "0", "0", "png", {}, "invalid_parameter"),
        tile("last tile on the plane", "0", big, "0", "png", {}, ""),
        tile("first tile off the plane", "0", over, "0", "png", {}, "coordinate_out_of_range"),
        tile("last tile on the plane, negative side", "0", low, "0", "png", {}, ""),
        tile("first tile off the plane, negative side", "0", "0", below, "png", {},
             "coordinate_out_of_range"),
        tile("a coarser level has a smaller plane", "1", big, "0", "png", {},
             "coordinate_out_of_range"),
        tile("index overflows int64", "0", "9223372036854775807", "0", "png", {},
             "coordinate_out_of_range"),
        tile("index is not an integer", "0", "1.5", "0", "png", {}, "coordinate_out_of_range"),
        tile("mni at its floor", "0", "0", "0", "png", {{"mni", "1"}}, ""),
        tile("mni under its floor", "0", "0", "0", "png", {{"mni", "0.999"}}, "invalid_parameter"),
        tile("mni at its ceiling", "0", "0", "0", "png", {{"mni", "200"}}, ""),
        tile("mni over its ceiling", "0", "0", "0", "png", {{"mni", "200.001"}},
             "invalid_parameter"),
        tile("mni is NaN", "0", "0", "0", "png", {{"mni", "nan"}}, "invalid_parameter"),
        tile("largest seed", "0", "0", "0", "png", {{"seed", "18446744073709551615"}}, ""),
        tile("seed overflows", "0", "0", "0", "png", {{"seed", "18446744073709551616"}},
             "invalid_parameter"),
        tile("negative seed", "0", "0", "0", "png", {{"seed", "-1"}}, "invalid_parameter"),
        tile("size 512", "0", "0", "0", "png", {{"size", "512"}}, ""),
        tile("size 384", "0", "0", "0", "png", {{"size", "384"}}, "invalid_parameter"),
        tile("unknown field", "0", "0", "0", "png", {{"sede", "1"}}, "unknown_parameter"),
        tile("a field twice", "0", "0", "0", "png", {{"seed", "1"}, {"seed", "2"}},
             "invalid_parameter"),
        {"bad id",
         [] {
             TileRequest t;
             return parse_tile("../../etc/passwd", "0", "0", "0", "png", {}, t);
         },
         "invalid_id"},
        {"upper-case id",
         [] {
             TileRequest t;
             return parse_tile(std::string(64, 'A'), "0", "0", "0", "png", {}, t);
         },
         "invalid_id"},
    });
}

TEST(Requests, TileValuesArriveInTheStruct) {
    TileRequest t;
    ASSERT_FALSE(parse_tile(kId, "-2", "-3", "5", "png16",
                            {{"seed", "9"}, {"mni", "12.5"}, {"size", "512"}}, t));
    EXPECT_EQ(t.id, kId);
    EXPECT_EQ(t.level, -2);
    EXPECT_EQ(t.x0(), -3 * 512);
    EXPECT_EQ(t.y0(), 5 * 512);
    EXPECT_EQ(t.format, ImageFormat::png16);
    EXPECT_EQ(t.noise.seed, 9u);
    EXPECT_EQ(t.noise.mni, 12.5);
    // The web map's zoom counts the other way: zoom 0 is the coarsest level.
    TileRequest m;
    ASSERT_FALSE(parse_map_tile(kId, "0", "0", "0", "png", {}, m));
    EXPECT_EQ(m.level, kMapMaxLevel);
    ASSERT_FALSE(parse_map_tile(kId, std::to_string(kMapMaxZoom), "0", "0", "png", {}, m));
    EXPECT_EQ(m.level, kMapMaxLevel - kMapMaxZoom);
    EXPECT_TRUE(parse_map_tile(kId, std::to_string(kMapMaxZoom + 1), "0", "0", "png", {}, m));
    EXPECT_TRUE(parse_map_tile(kId, "-1", "0", "0", "png", {}, m));
}

Row region(std::string what, Query q, std::string code, std::int64_t max_pixels = 8'388'608) {
    return {std::move(what),
            [=] {
                RegionRequest r;
                Limits limits;
                limits.max_region_pixels = max_pixels;
                return parse_region(kId, "png", q, limits, r);
            },
            std::move(code)};
}

TEST(Requests, RegionTable) {
    const std::string edge = std::to_string((std::int64_t{1} << 62) - 100);
    check({
        region("defaults", {}, ""),
        region("widest", {{"w", "16384"}, {"h", "1"}}, ""),
        region("too wide", {{"w", "16385"}, {"h", "1"}}, "invalid_parameter"),
        region("empty", {{"w", "0"}}, "invalid_parameter"),
        region("at the pixel budget", {{"w", "100"}, {"h", "100"}}, "", 10000),
        region("over the pixel budget", {{"w", "100"}, {"h", "101"}}, "region_too_large", 10000),
        region("at the plane's edge", {{"x", edge}, {"w", "100"}}, ""),
        region("over the plane's edge", {{"x", edge}, {"w", "101"}}, "coordinate_out_of_range"),
        region("x not an integer", {{"x", "1e3"}}, "coordinate_out_of_range"),
        region("level out of range", {{"z", "25"}}, "level_out_of_range"),
        region("mni out of range", {{"mni", "201"}}, "invalid_parameter"),
        region("tile-only field", {{"size", "256"}}, "unknown_parameter"),
    });
}

TEST(Requests, TileableListAndKitTables) {
    auto tileable = [](std::string what, Query q, std::string code) {
        return Row{std::move(what),
                   [=] {
                       TileableRequest t;
                       Limits limits;
                       limits.max_tileable_side = 1024;
                       return parse_tileable(kId, "exr", q, limits, t);
                   },
                   std::move(code)};
    };
    auto list = [](std::string what, Query q, std::string code) {
        return Row{std::move(what),
                   [=] {
                       ListRequest l;
                       return parse_list(q, l);
                   },
                   std::move(code)};
    };
    auto kit = [](std::string what, Query q, std::string code) {
        return Row{std::move(what),
                   [=] {
                       NoiseParams n;
                       return parse_kit(kId, q, n);
                   },
                   std::move(code)};
    };
    check({
        tileable("smallest", {{"w", "8"}, {"h", "8"}}, ""),
        tileable("too small", {{"w", "7"}}, "invalid_parameter"),
        tileable("largest", {{"w", "1024"}, {"h", "1024"}}, ""),
        tileable("over the configured side", {{"h", "1025"}}, "invalid_parameter"),
        list("defaults", {}, ""),
        list("limit 1", {{"limit", "1"}}, ""),
        list("limit 0", {{"limit", "0"}}, "invalid_parameter"),
        list("limit 1000", {{"limit", "1000"}}, ""),
        list("limit 1001", {{"limit", "1001"}}, "invalid_parameter"),
        list("cursor", {{"after", kId}}, ""),
        list("cursor that is no id", {{"after", "zz"}}, "invalid_id"),
        kit("mni", {{"mni", "45"}}, ""),
        kit("seed is not a kit field", {{"seed", "1"}}, "unknown_parameter"),
        kit("mni under its floor", {{"mni", "0.5"}}, "invalid_parameter"),
    });
}

TEST(Requests, AnalysisTable) {
    auto analysis = [](std::string what, Query q, std::string code) {
        return Row{std::move(what),
                   [=] {
                       core::AnalysisParams p;
                       return parse_analysis(q, p);
                   },
                   std::move(code)};
    };
    check({
        analysis("defaults", {}, ""),
        analysis("smallest support", {{"size", "8"}}, ""),
        analysis("support too small", {{"size", "7"}}, "invalid_parameter"),
        analysis("largest support", {{"size", "256"}}, ""),
        analysis("support too large", {{"size", "257"}}, "invalid_parameter"),
        analysis("nearest", {{"order", "0"}}, ""),
        analysis("cubic", {{"order", "3"}}, ""),
        analysis("no quadratic", {{"order", "2"}}, "invalid_parameter"),
        analysis("order 4", {{"order", "4"}}, "invalid_parameter"),
        analysis("one iteration", {{"iterations", "1"}}, ""),
        analysis("no iterations", {{"iterations", "0"}}, "invalid_parameter"),
        analysis("most iterations", {{"iterations", "1000"}}, ""),
        analysis("too many iterations", {{"iterations", "1001"}}, "invalid_parameter"),
        analysis("periodic false", {{"periodic", "false"}}, ""),
        analysis("periodic maybe", {{"periodic", "maybe"}}, "invalid_parameter"),
        analysis("typo", {{"iteration", "5"}}, "unknown_parameter"),
    });
    core::AnalysisParams p;
    ASSERT_FALSE(parse_analysis(
        {{"size", "48"}, {"order", "3"}, {"iterations", "7"}, {"seed", "5"}, {"periodic", "0"}},
        p));
    EXPECT_EQ(p.size, 48);
    EXPECT_EQ(p.order, 3);
    EXPECT_EQ(p.iterations, 7);
    EXPECT_EQ(p.seed, 5u);
    EXPECT_FALSE(p.periodic);
}

TEST(Requests, MixAndSurfaceTables) {
    const std::string other(64, 'b');
    auto mix = [&](std::string what, Query q, bool mask, std::string code) {
        q.emplace("u", kId);
        q.emplace("v", other);
        return Row{std::move(what),
                   [=] {
                       MixRequest m;
                       return parse_mix(q, mask, m);
                   },
                   std::move(code)};
    };
    auto surface = [](std::string what, Query q, bool mesh, std::string code) {
        return Row{std::move(what),
                   [=] {
                       SurfaceParams s;
                       return parse_surface(kId, q, mesh, s);
                   },
                   std::move(code)};
    };
    check({
        mix("ramp defaults", {}, false, ""),
        mix("fewest levels", {{"levels", "2"}}, false, ""),
        mix("one level", {{"levels", "1"}}, false, "invalid_parameter"),
        mix("most levels", {{"levels", std::to_string(core::kMaxMixLevels)}}, false, ""),
        mix("too many levels", {{"levels", std::to_string(core::kMaxMixLevels + 1)}}, false,
            "invalid_parameter"),
        mix("ramp of no width", {{"width", "0"}}, false, "invalid_parameter"),
        mix("scale without a mask", {{"scale", "2"}}, false, "invalid_parameter"),
        mix("mask placement", {{"scale", "2"}, {"x0", "-10"}}, true, ""),
        mix("infinite offset", {{"x0", "inf"}}, false, "invalid_parameter"),
        {"mix without v",
         [] {
             MixRequest m;
             return parse_mix({{"u", kId}}, false, m);
         },
         "invalid_parameter"},
        surface("defaults", {}, false, ""),
        surface("mni at its floor", {{"mni", "1"}}, false, ""),
        surface("mni under its floor", {{"mni", "0.99"}}, false, "invalid_parameter"),
        surface("mni at its ceiling", {{"mni", "200"}}, false, ""),
        surface("mni over its ceiling", {{"mni", "200.5"}}, false, "invalid_parameter"),
        surface("camera is a mesh field", {{"fov", "40"}}, false, "unknown_parameter"),
        surface("narrowest view", {{"fov", "5"}}, true, ""),
        surface("too narrow a view", {{"fov", "4.9"}}, true, "invalid_parameter"),
        surface("smallest mesh image", {{"width", "16"}, {"height", "16"}}, true, ""),
        surface("mesh image too large", {{"width", "2049"}}, true, "invalid_parameter"),
        surface("eye without target", {{"eye", "0,0,5"}}, true, "invalid_parameter"),
        surface("eye and target", {{"eye", "0,0,5"}, {"target", "0,0,0"}}, true, ""),
        surface("eye of two numbers", {{"eye", "0,5"}, {"target", "0,0,0"}}, true,
                "invalid_parameter"),
    });
}

TEST(Requests, StrictNumbers) {
    EXPECT_FALSE(parse_i64("+12")) << "one spelling per value";
    EXPECT_EQ(parse_i64("-12"), -12);
    EXPECT_EQ(parse_i64("0"), 0);
    for (const char* other : {"-0", "012", "00", "+0", " 1", "1e2", "1.0"})
        EXPECT_FALSE(parse_i64(other)) << other;
    EXPECT_EQ(parse_decimal("0.25"), 0.25);
    EXPECT_EQ(parse_decimal("-3"), -3.0);
    for (const char* other :
         {"0x10", " 16", "16 ", "+16", "016", "16.0", "16.", ".5", "1e1", "-0", "-0.0", "0.50"})
        EXPECT_FALSE(parse_decimal(other)) << other;
    EXPECT_EQ(parse_i64("-9223372036854775808"), INT64_MIN);
    EXPECT_FALSE(parse_i64("9223372036854775808"));
    EXPECT_FALSE(parse_i64(""));
    EXPECT_FALSE(parse_i64("12 "));
    EXPECT_FALSE(parse_i64("0x10"));
    EXPECT_FALSE(parse_u64("-1"));
    EXPECT_FALSE(parse_u64("+1"));
    EXPECT_EQ(parse_finite("1e3"), 1000.0);
    EXPECT_FALSE(parse_finite("inf"));
    EXPECT_FALSE(parse_finite("nan"));
    EXPECT_FALSE(parse_finite("1e999"));
    EXPECT_FALSE(parse_finite(std::string(65, '1')));
}

// A tileable texture is held to a region's pixels, whatever its sides allow.
TEST(Requests, TileableTexturesHaveARegionsPixelsAtMost) {
    Limits limits; // 4096 a side, 8388608 pixels
    TileableRequest t;
    EXPECT_FALSE(parse_tileable(kId, "png", {{"w", "4096"}, {"h", "2048"}}, limits, t));
    const auto e = parse_tileable(kId, "png", {{"w", "4096"}, {"h", "2056"}}, limits, t);
    ASSERT_TRUE(e);
    EXPECT_EQ(e->code, "region_too_large");
    EXPECT_NE(e->message.find("8388608"), std::string::npos) << e->message;
}

// One image, one URL: every other spelling of a number a URL carries is refused, with the one to
// use in the message (mni=0x10, quality=050, a tile's +0 were all served under new cache keys).
TEST(Requests, NumbersInUrlsHaveOneSpellingAndTheMessageNamesIt) {
    auto message = [](const std::optional<ApiError>& e) { return e ? e->message : "accepted"; };
    TileRequest t;
    EXPECT_NE(message(parse_tile(kId, "0", "+0", "0", "png", {}, t)).find("write 0"),
              std::string::npos);
    EXPECT_NE(message(parse_tile(kId, "0", "0", "-0", "png", {}, t)).find("write 0"),
              std::string::npos);
    EXPECT_NE(message(parse_tile(kId, "007", "0", "0", "png", {}, t)).find("write 7"),
              std::string::npos);
    EXPECT_NE(message(parse_tile(kId, "0", "0", "0", "png", {{"mni", "0x10"}}, t)).find("write 16"),
              std::string::npos);
    EXPECT_NE(message(parse_tile(kId, "0", "0", "0", "png", {{"mni", " 10"}}, t)).find("write 10"),
              std::string::npos);
    EXPECT_NE(
        message(parse_tile(kId, "0", "0", "0", "webp", {{"quality", "+50"}}, t)).find("write 50"),
        std::string::npos);
    EXPECT_NE(
        message(parse_tile(kId, "0", "0", "0", "webp", {{"quality", "050"}}, t)).find("write 50"),
        std::string::npos);
    EXPECT_NE(
        message(parse_tile(kId, "0", "0", "0", "png", {{"seed", "0042"}}, t)).find("write 42"),
        std::string::npos);
    TileRequest elevation, normal; // fresh: a parser fills what it reads before it refuses
    EXPECT_NE(
        message(parse_tile(kId, "0", "0", "0", "png",
                           {{"map", "height"}, {"encoding", "mapbox"}, {"height_scale", "5.0"}},
                           elevation))
            .find("write 5"),
        std::string::npos);
    EXPECT_NE(message(parse_tile(kId, "0", "0", "0", "png", {{"map", "normal"}, {"strength", "05"}},
                                 normal))
                  .find("write 5"),
              std::string::npos);
    EXPECT_EQ(message(parse_tile(kId, "0", "0", "0", "png", {{"mni", "2.5"}, {"seed", "42"}}, t)),
              "accepted");
    EXPECT_NE(message(parse_tile(kId, "0", "0", "0", "png", {{"mni", "30.00000000000000001"}}, t))
                  .find("write 30"),
              std::string::npos)
        << "the same double as 30";
    // What the server writes into URLs reads back as the same number and is accepted.
    for (double v : {1.1, 30.0, 0.000001, 199.99, 1.0 / 3.0, 1e21, -4.5e30}) {
        const std::string text = query_text(v);
        EXPECT_EQ(parse_decimal(text), v) << text;
        EXPECT_EQ(text.find('e'), std::string::npos) << text;
    }
    // A hint names a spelling that is accepted, for large numbers too.
    const std::string hint = canonical_hint("1e21");
    EXPECT_NE(hint.find("write 1000000000000000000000)"), std::string::npos) << hint;
    EXPECT_EQ(query_text(30.0), "30");
    EXPECT_EQ(query_text(1.1), "1.1");
}

Query split_query(const std::string& text) {
    Query q;
    std::size_t at = 0;
    while (at < text.size()) {
        const std::size_t amp = std::min(text.find('&', at), text.size());
        const std::string item = text.substr(at, amp - at);
        const std::size_t eq = item.find('=');
        q.emplace(item.substr(0, eq), item.substr(eq + 1));
        at = amp + 1;
    }
    return q;
}

// Every field a URL writes reads back to the same value: TileJSON's templates and the cache's
// keys name the image the parser will make.
TEST(NoiseFields, WhatAUrlWritesReadsBack) {
    NoiseParams lit;
    lit.seed = 18446744073709551615ULL;
    lit.mni = 12.5;
    lit.exemplar_marginals = true;
    lit.map.name = core::kLitMap;
    lit.map.strength = 2.25;
    lit.map.azimuth = 30.5;
    lit.map.elevation = 45;
    NoiseParams normal;
    normal.mni = 1.5;
    normal.map.name = core::kNormalMap;
    normal.map.strength = 0.000001;
    NoiseParams elevation;
    elevation.map.name = core::kHeightMap;
    elevation.map.encoding = core::ElevationEncoding::mapbox;
    elevation.map.height_scale = 0.125;
    for (const NoiseParams& p : {lit, normal, elevation, NoiseParams{}})
        for (NoiseRoute route : {kTileRoute, kRegionRoute, kTileableRoute}) {
            const std::string text = noise_query(p, route);
            SCOPED_TRACE(text);
            NoiseParams back;
            const auto e = read_noise_fields(split_query(text), route, back);
            ASSERT_FALSE(e) << e->message;
            EXPECT_EQ(back.seed, p.seed);
            EXPECT_EQ(back.mni, p.mni);
            EXPECT_EQ(back.exemplar_marginals, p.exemplar_marginals);
            EXPECT_EQ(back.map.name, p.map.name);
            if (p.map.uses_normals()) {
                EXPECT_EQ(back.map.strength, p.map.strength);
            }
            if (p.map.name == core::kLitMap) {
                EXPECT_EQ(back.map.azimuth, p.map.azimuth);
                EXPECT_EQ(back.map.elevation, p.map.elevation);
            }
            if (route == kTileRoute) { // elevation tiles are tiles only
                EXPECT_EQ(back.map.encoding, p.map.encoding);
                EXPECT_EQ(back.map.height_scale, p.map.height_scale);
            }
        }
    EXPECT_EQ(noise_query(elevation, kTileRoute),
              "seed=0&mni=30&map=height&encoding=mapbox&height_scale=0.125");
    EXPECT_EQ(noise_query(lit, kReportRoute), "seed=18446744073709551615&mni=12.5");
    EXPECT_EQ(noise_query(lit, kKitRoute), "mni=12.5");
}

// Each parser takes exactly the noise fields the table gives its route: a row's field is read
// (its bad value gives invalid_parameter) where the row names the route and is unknown elsewhere.
TEST(NoiseFields, EachParserTakesItsRoutesRows) {
    const Limits limits;
    const std::vector<std::pair<NoiseRoute, std::function<std::optional<ApiError>(const Query&)>>>
        parsers = {
            {kTileRoute,
             [](const Query& q) {
                 TileRequest t;
                 return parse_tile(kId, "0", "0", "0", "png", q, t);
             }},
            {kTileRoute,
             [](const Query& q) {
                 TileRequest t;
                 return parse_tilejson(kId, q, t);
             }},
            {kRegionRoute,
             [&](const Query& q) {
                 RegionRequest r;
                 return parse_region(kId, "png", q, limits, r);
             }},
            {kMixTileRoute,
             [](const Query& q) {
                 TileRequest t;
                 return parse_map_tile(kId, "0", "0", "0", "png", q, t, false);
             }},
            {kMixTileRoute,
             [](const Query& q) {
                 TileRequest t;
                 return parse_tilejson(kId, q, t, false);
             }},
            {kMixRegionRoute,
             [&](const Query& q) {
                 RegionRequest r;
                 return parse_region(kId, "png", q, limits, r, false);
             }},
            {kTileableRoute,
             [&](const Query& q) {
                 TileableRequest t;
                 return parse_tileable(kId, "png", q, limits, t);
             }},
            {kReportRoute,
             [](const Query& q) {
                 NoiseParams n;
                 return parse_spectrum(kId, q, n);
             }},
            {kKitRoute,
             [](const Query& q) {
                 NoiseParams n;
                 return parse_kit(kId, q, n);
             }},
            {kSurfaceRoute,
             [](const Query& q) {
                 SurfaceParams p;
                 return parse_surface(kId, q, false, p);
             }},
            {kMeshRoute,
             [](const Query& q) {
                 SurfaceParams p;
                 return parse_surface(kId, q, true, p);
             }},
        };
    int taken = 0;
    for (const auto& [route, parse] : parsers)
        for (const NoiseField& f : kNoiseFields) {
            SCOPED_TRACE(std::string(f.name) + " on route bit " + std::to_string(route));
            const auto e = parse(Query{{f.name, "x!"}});
            ASSERT_TRUE(e);
            EXPECT_EQ(e->code, (f.routes & route) ? "invalid_parameter" : "unknown_parameter")
                << e->message;
            if (f.routes & route) {
                EXPECT_NE(e->message.find(f.name), std::string::npos) << e->message;
                ++taken;
            }
        }
    // 8 fields on the tile and TileJSON parsers (encoding, height_scale: tiles only), 6 on the
    // region and tileable parsers; 3 on a mix's; 4 on the surface; 6 on the mesh; 2 on the
    // reports; 1 on the kit.
    EXPECT_EQ(taken, 50);
}

// An item with two '=' would be read as what follows the last one: refused, whole.
TEST(QueryText, AnItemWithTwoEqualsIsRefused) {
    for (const char* bad : {"seed=1=5", "seed=1;mni=2", "mni=30&seed==1", "a=b=c&x=1"}) {
        const auto e = check_query_text(bad);
        ASSERT_TRUE(e) << bad;
        EXPECT_EQ(e->code, "invalid_parameter");
    }
    for (const char* good :
         {"", "seed=1&mni=30", "light=30,45&map=lit", "seed=1%3D5", "flag", "a=&b="})
        EXPECT_FALSE(check_query_text(good)) << good;
}

// nlohmann's reader stops at a NUL byte: a body with one is refused whole, not read up to it.
TEST(JsonBody, ANulByteIsRefusedNotTakenForTheEnd) {
    using namespace std::string_literals;
    EXPECT_FALSE(check_json_bounds(R"({"strength": 1})", 4, 512));
    for (const std::string& bad :
         {"{\"strength\": 1}\0"s, "{\"strength\": 1}\0{\"x\": 2}"s, "{\"a\": \"b\0c\"}"s}) {
        const auto e = check_json_bounds(bad, 4, 512);
        ASSERT_TRUE(e) << bad.size();
        EXPECT_EQ(e->code, "invalid_body");
    }
    std::vector<float> points, normals;
    const std::string surface = R"({"points": [[0, 0, 0]], "normals": [[0, 0, 1]]})";
    EXPECT_FALSE(parse_surface_json(surface, 10, points, normals));
    const auto e = parse_surface_json(surface + "\0"s + "junk", 10, points, normals);
    ASSERT_TRUE(e);
    EXPECT_EQ(e->code, "invalid_body");
}

} // namespace
} // namespace textond::api
