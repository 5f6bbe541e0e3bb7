// The store across restarts of the real binary: kill -9 during an upload leaves the texton
// complete or absent; a damaged file is quarantined (when first read) and reported, never
// served; SIGTERM lets a request in flight finish.
#include "server/io/image_io.h"
#include "server/io/texton_file.h"
#include "server/store/quarantine.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>
#include <thread>

namespace textond::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A 64 x 64 crop of a shared photo as PNG: its 16 x 16 (or 32 x 32) texton and the exemplar fit
// under the full-disk tests' 40 kB a file.
std::string tiny_exemplar(const std::string& name) {
    return io::encode_image_memory(test::crop(load_exemplar(name), 64, 64), io::Encoding::png8)
        .value();
}

int files_in(const std::string& dir) {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir)) n += e.is_regular_file();
    return n;
}

TEST(Store, KillDuringUploadsLeavesCompleteOrAbsentTextons) {
    const std::string data = fresh_dir("store-kill");
    const std::string body = read_file(exemplar_path("skimage_grass.png"));
    // Kill at several moments: before, during and after the analysis and its write.
    for (int delay_ms : {5, 40, 120, 300}) {
        SCOPED_TRACE(delay_ms);
        {
            ServerProcess server(data);
            std::thread uploader([&] {
                auto c = server.client();
                c.Post(
                    ("/v1/textons?size=32&iterations=40&seed=" + std::to_string(delay_ms)).c_str(),
                    body, "image/png");
            });
            std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
            server.kill_hard();
            uploader.join();
        }
        ServerProcess again(data);
        auto c = again.client();
        auto ready = c.Get("/readyz");
        ASSERT_TRUE(ready);
        EXPECT_EQ(ready->status, 200);
        EXPECT_TRUE(json::parse(ready->body)["store"]["quarantined"].empty()) << ready->body;
        const json list = json::parse(c.Get("/v1/textons")->body);
        for (const auto& t : list["items"]) {
            const std::string id = t["id"];
            auto exr = c.Get(("/v1/textons/" + id + "/texton.exr").c_str());
            EXPECT_EQ(exr->status, 200); // verified (checksum) on the way out
            EXPECT_EQ(c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str())->status, 200);
        }
        // No temporary file survives a restart.
        for (const auto& e : fs::directory_iterator(data + "/textons"))
            EXPECT_NE(e.path().filename().string()[0], '.') << e.path();
        EXPECT_EQ(files_in(data + "/textons"), static_cast<int>(list["items"].size()));
        // An exemplar written just before the kill, without its texton, is gone too.
        EXPECT_EQ(files_in(data + "/exemplars"), static_cast<int>(list["items"].size()));
    }
}

// Quarantine directories only grow: what /readyz and /metrics read of one is its first 100
// names and a count, however many files it holds (300,000 had made each /readyz copy and sort
// them all). Regular files only, dot-files aside; a mix's two files are one mix.
TEST(Store, QuarantineListsKeepTheirFirstNamesAndCountAll) {
    const std::string dir = fresh_dir("store-quarantine-list");
    fs::create_directories(dir + "/quarantine/sub");
    for (int i = 0; i < 150; ++i) {
        char id[65];
        std::snprintf(id, sizeof id, "%064x", 150 - i);
        std::ofstream(dir + "/quarantine/" + id + ".exr.1");
        std::ofstream(dir + "/quarantine/" + id + ".mask.exr.1");
    }
    std::ofstream(dir + "/quarantine/.hidden");
    const store::QuarantineList files = store::quarantined_on_disk(dir, false);
    EXPECT_EQ(files.count(), 300u);
    EXPECT_EQ(files.names().size(), store::QuarantineList::kListed);
    store::QuarantineList ids = store::quarantined_on_disk(dir, true);
    EXPECT_EQ(ids.count(), 150u);
    ASSERT_EQ(ids.names().size(), 100u);
    EXPECT_EQ(ids.names().front(), std::string(63, '0') + "1");
    EXPECT_TRUE(std::is_sorted(ids.names().begin(), ids.names().end()));
    ids.add(ids.names().front()); // listed already: not counted again
    EXPECT_EQ(ids.count(), 150u);
    ids.add(std::string(64, '0')); // first by name: listed, the last listed one drops
    EXPECT_EQ(ids.count(), 151u);
    EXPECT_EQ(ids.names().front(), std::string(64, '0'));
    EXPECT_EQ(ids.names().size(), 100u);
}

TEST(Store, DamagedFileIsQuarantinedAndReportedNeverServed) {
    const std::string data = fresh_dir("store-damage");
    std::string id;
    {
        ServerProcess server(data);
        auto c = server.client();
        id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
        upload(c, "etr_pebbles04.png", "?size=16&iterations=5");
        ASSERT_EQ(server.terminate(10000), 0);
    }
    // Flip bytes in the middle of the coefficients of one texton.
    const std::string path = data + "/textons/" + id + ".exr";
    std::string bytes = read_file(path);
    for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 64; ++i) bytes[i] ^= 0x5a;
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;

    // Files are verified when first read, not when the store opens (readiness does not wait on
    // the store's size): the first request for the damaged texton finds it out.
    ServerProcess server(data);
    auto c = server.client();
    EXPECT_EQ(json::parse(c.Get("/readyz")->body)["store"]["textons"], 2);
    EXPECT_EQ(c.Get(("/v1/textons/" + id).c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str())->status, 404);
    auto ready = c.Get("/readyz");
    ASSERT_TRUE(ready);
    const json r = json::parse(ready->body);
    ASSERT_EQ(r["store"]["quarantined"].size(), 1u) << ready->body;
    EXPECT_EQ(r["store"]["quarantined"][0].get<std::string>().rfind(id, 0), 0u);
    EXPECT_EQ(r["store"]["textons"], 1);
    EXPECT_FALSE(fs::exists(path));
    EXPECT_EQ(files_in(data + "/quarantine"), 1);
    EXPECT_EQ(files_in(data + "/exemplars"), 1); // the damaged texton's exemplar went with it
    EXPECT_NE(c.Get("/metrics")->body.find("textond_store_quarantined 1"), std::string::npos);
    // The same upload again analyses afresh and serves.
    int status = 0;
    EXPECT_EQ(upload(c, "etr_sand01.png", "?size=16&iterations=5", &status), id);
    EXPECT_EQ(status, 201);
    ASSERT_EQ(server.terminate(10000), 0);
    // A restart still reports what the quarantine directory holds.
    ServerProcess again(data);
    auto c2 = again.client();
    const json r2 = json::parse(c2.Get("/readyz")->body);
    ASSERT_EQ(r2["store"]["quarantined"], r["store"]["quarantined"]);
    EXPECT_NE(c2.Get("/metrics")->body.find("textond_store_quarantined 1"), std::string::npos);
}

// A texton file removed behind the server's back is forgotten, not quarantined: 404 saying so,
// nothing counted or listed as quarantined (it had been logged and counted as "moved to
// quarantine" with nothing moved); its exemplar gone the same way says it may have been removed.
TEST(Store, AFileRemovedOutsideTheServerIsForgottenNotQuarantined) {
    const std::string data = fresh_dir("store-removed");
    ServerProcess server(data);
    auto c = server.client();
    const std::string gone = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    const std::string kept = upload(c, "etr_pebbles04.png", "?size=16&iterations=5");
    fs::remove(data + "/textons/" + gone + ".exr");
    fs::remove(data + "/exemplars/" + kept + ".png");
    auto tile = c.Get(("/v1/textons/" + gone + "/tiles/0/0/0.png").c_str());
    ASSERT_TRUE(tile);
    EXPECT_EQ(tile->status, 404);
    EXPECT_NE(tile->body.find("no longer on disk"), std::string::npos) << tile->body;
    EXPECT_EQ(c.Get(("/v1/textons/" + gone).c_str())->status, 404);
    const json r = json::parse(c.Get("/readyz")->body);
    EXPECT_EQ(r["store"]["quarantined"].size(), 0u) << r.dump();
    EXPECT_EQ(files_in(data + "/quarantine"), 0);
    EXPECT_NE(c.Get("/metrics")->body.find("textond_store_quarantined 0"), std::string::npos);
    auto exemplar = c.Get(("/v1/textons/" + kept + "/exemplar.png").c_str());
    ASSERT_TRUE(exemplar);
    EXPECT_EQ(exemplar->status, 404);
    EXPECT_NE(exemplar->body.find("removed from the disk since"), std::string::npos)
        << exemplar->body;
}

// A data directory that takes no new file (read-only, or its folder replaced) refuses an upload
// with 503 before its analysis, as /readyz already says; it had run the whole analysis, then
// answered 500.
TEST(Store, AnUnwritableDataDirectoryRefusesUploadsBeforeTheirAnalysis) {
    const std::string data = fresh_dir("store-unwritable");
    ServerProcess server(data);
    auto c = server.client();
    upload(c, "etr_sand01.png", "?size=16&iterations=5");
    fs::rename(data + "/textons", data + "/textons.moved");
    std::ofstream(data + "/textons") << "not a folder";
    EXPECT_EQ(c.Get("/readyz")->status, 503);
    auto refused = c.Post("/v1/textons?size=64&iterations=300",
                          read_file(exemplar_path("mypaint_HR_Cork.png")), "image/png");
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->status, 503) << refused->body;
    EXPECT_NE(refused->body.find("takes no new file"), std::string::npos) << refused->body;
}

// An exemplar damaged on disk (cut short) is the store's error, not the client's: 500
// storage_error from its own route, the quality report, the spectrum and a mix of it, never its
// bytes; the texton itself still serves tiles.
TEST(Store, ADamagedExemplarIsAStorageErrorNeverServed) {
    const std::string data = fresh_dir("store-exemplar");
    ServerProcess server(data);
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    const std::string other = upload(c, "etr_pebbles04.png", "?size=16&iterations=5");
    const std::string path = data + "/exemplars/" + id + ".png";
    std::ofstream(path, std::ios::binary | std::ios::trunc) << read_file(path).substr(0, 100);
    const std::string base = "/v1/textons/" + id;
    for (const std::string& url :
         {base + "/exemplar.png", base + "/quality.json", base + "/spectrum.png"}) {
        auto r = c.Get(url.c_str());
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 500) << url << ": " << r->body;
        EXPECT_EQ(json::parse(r->body)["error"]["code"], "storage_error") << url;
    }
    auto mix = c.Post(("/v1/mixes?u=" + id + "&v=" + other + "&levels=2").c_str());
    ASSERT_TRUE(mix);
    EXPECT_EQ(mix->status, 500) << mix->body;
    EXPECT_EQ(c.Get((base + "/tiles/0/0/0.png").c_str())->status, 200);
    // Whole but with bytes flipped inside its pixels (their chunk's CRC fails): not served either.
    const std::string third = upload(c, "skimage_gravel.png", "?size=16&iterations=5");
    const std::string flipped = data + "/exemplars/" + third + ".png";
    std::string bytes = read_file(flipped);
    for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 16; ++i) bytes[i] ^= 0x5a;
    std::ofstream(flipped, std::ios::binary | std::ios::trunc) << bytes;
    auto r = c.Get(("/v1/textons/" + third + "/exemplar.png").c_str());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 500) << r->body;
}

// The kill -9 test cannot land between a write and its rename (writes take microseconds), so
// the server is stopped there on purpose (server/io/crash_point.h): after the exemplar's write,
// after the texton's write, after its rename and after its directory's fsync. Each time the
// process must have reached the point (exit 86), and after a restart the texton is absent (the
// same upload creates it) or whole (the same upload finds it and its tile renders), with no
// temporary file left and nothing quarantined.
TEST(Store, ACrashAtEachPointOfATextonWriteLeavesItWholeOrAbsent) {
    const struct {
        const char* point;
        bool whole;
    } cases[] = {{"png-written", false},
                 {"exr-written", false},
                 {"exr-renamed", true},
                 {"texton-synced", true}};
    const std::string body = read_file(exemplar_path("etr_sand01.png"));
    for (const auto& k : cases) {
        const std::string data = fresh_dir(std::string("store-crash-") + k.point);
        {
            ::setenv("TEXTOND_CRASH_POINT", k.point, 1);
            ServerProcess server(data);
            ::unsetenv("TEXTOND_CRASH_POINT");
            auto c = server.client();
            auto res = c.Post("/v1/textons?size=16&iterations=5", body, "image/png");
            EXPECT_FALSE(res) << k.point << ": answered " << res->status;
            EXPECT_EQ(server.terminate(10000), 86) << k.point << " was not reached";
        }
        ServerProcess server(data);
        auto c = server.client();
        auto ready = c.Get("/readyz");
        ASSERT_TRUE(ready);
        EXPECT_TRUE(json::parse(ready->body)["store"]["quarantined"].empty()) << k.point;
        // A listing waits for the scan of the names, which also clears what the crash left.
        ASSERT_EQ(c.Get("/v1/textons")->status, 200);
        for (const char* dir : {"/textons", "/exemplars", "/provenance"})
            for (const auto& e : fs::directory_iterator(data + dir))
                EXPECT_NE(e.path().filename().string()[0], '.') << k.point << ": " << e.path();
        EXPECT_EQ(files_in(data + "/textons"), k.whole ? 1 : 0) << k.point;
        int status = 0;
        const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=5", &status);
        EXPECT_EQ(status, k.whole ? 200 : 201) << k.point;
        auto tile = c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str());
        ASSERT_TRUE(tile);
        EXPECT_EQ(tile->status, 200) << k.point;
    }
}

// Bit rot the decoder cannot see: one coefficient changed in a file that is otherwise whole (a
// valid EXR with its metadata and id), so only the SHA-256 of the coefficients catches it.
TEST(Store, AFileThatDecodesButFailsItsChecksumIsQuarantinedNeverServed) {
    const std::string data = fresh_dir("store-checksum");
    std::string id;
    {
        ServerProcess server(data);
        auto c = server.client();
        id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
        ASSERT_EQ(server.terminate(10000), 0);
    }
    const std::string path = data + "/textons/" + id + ".exr";
    auto record = io::read_texton_file(path);
    ASSERT_TRUE(record.ok()) << record.error().message;
    record.value().texton.alpha.data[17] += 1e-3f; // the metadata keeps the old checksum
    ASSERT_TRUE(io::write_texton_file(path, record.value()).ok());
    ASSERT_TRUE(io::decode_image_file(path).ok()) << "the damage must decode cleanly";
    auto reread = io::read_texton_file(path);
    ASSERT_FALSE(reread.ok());
    EXPECT_NE(reread.error().message.find("checksum"), std::string::npos) << reread.error().message;

    ServerProcess server(data);
    auto c = server.client();
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/texton.exr").c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/textons/" + id).c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str())->status, 404);
    auto ready = c.Get("/readyz");
    ASSERT_TRUE(ready);
    const json r = json::parse(ready->body);
    ASSERT_EQ(r["store"]["quarantined"].size(), 1u) << ready->body;
    EXPECT_EQ(r["store"]["quarantined"][0].get<std::string>().rfind(id, 0), 0u);
    EXPECT_FALSE(fs::exists(path));
}

TEST(Store, SigtermFinishesTheRequestInFlight) {
    const std::string data = fresh_dir("store-sigterm");
    ServerProcess server(data);
    int status = 0;
    std::thread uploader([&] {
        auto c = server.client();
        auto res = c.Post("/v1/textons?size=64&iterations=150",
                          read_file(exemplar_path("mypaint_HR_Cork.png")), "image/png");
        status = res ? res->status : -1;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    EXPECT_EQ(server.terminate(60000), 0);
    uploader.join();
    EXPECT_EQ(status, 201);
    EXPECT_EQ(files_in(data + "/textons"), 1);
}

TEST(Store, FullDiskAnswers507AndLosesNothing) {
    const std::string data = fresh_dir("store-full");
    ServerProcess server(data, {}, 40'000); // no file over 40 kB can be written
    auto c = server.client();
    // A 64 x 64 exemplar and its 16 x 16 texton fit; a 256 x 256 exemplar does not.
    const std::string tiny = tiny_exemplar("etr_sand01.png");
    auto first = c.Post("/v1/textons?size=16&iterations=5", tiny, "image/png");
    ASSERT_TRUE(first);
    ASSERT_EQ(first->status, 201) << first->body;
    const std::string small = json::parse(first->body).at("id");
    const json ready = json::parse(c.Get("/readyz")->body).at("store");
    EXPECT_TRUE(ready.at("no_space").is_null()) << ready.dump();
    EXPECT_GT(ready.at("free_bytes").get<std::uint64_t>(), 0u);
    auto full = c.Post("/v1/textons?size=96&iterations=5",
                       read_file(exemplar_path("etr_sand01.png")), "image/png");
    ASSERT_TRUE(full);
    EXPECT_EQ(full->status, 507) << full->body;
    EXPECT_EQ(json::parse(full->body)["error"]["code"], "insufficient_storage");
    // Nothing half-written, the old texton intact and served, the server healthy.
    EXPECT_EQ(files_in(data + "/textons"), 1);
    EXPECT_EQ(files_in(data + "/exemplars"), 1);
    EXPECT_EQ(c.Get(("/v1/textons/" + small + "/texton.exr").c_str())->status, 200);
    EXPECT_EQ(c.Get(("/v1/textons/" + small + "/tiles/0/0/0.png").c_str())->status, 200);
    EXPECT_EQ(json::parse(c.Get("/v1/textons")->body).at("total"), 1);
    EXPECT_EQ(c.Get("/healthz")->status, 200);
    // Readiness cannot see it by its two-byte probe; it says the write that was refused.
    const json after = json::parse(c.Get("/readyz")->body).at("store");
    EXPECT_TRUE(after.at("writable").get<bool>());
    EXPECT_NE(after.at("no_space").get<std::string>().find("File too large"), std::string::npos)
        << after.dump();
}

// A splat whose second weight image does not fit: 507, and its first is not left behind (a
// weights file without its metadata had stayed on disk).
TEST(Store, ASplatTheDiskCannotHoldLeavesNoFile) {
    const std::string data = fresh_dir("store-full-splat");
    ServerProcess server(data, {}, 40'000);
    auto c = server.client();
    const std::string tiny = tiny_exemplar("etr_sand01.png");
    std::string ids;
    for (int seed = 1; seed <= 5; ++seed) {
        auto r = c.Post(("/v1/textons?size=16&iterations=5&seed=" + std::to_string(seed)).c_str(),
                        tiny, "image/png");
        ASSERT_TRUE(r);
        ASSERT_EQ(r->status, 201) << r->body;
        ids += (ids.empty() ? "" : ",") + json::parse(r->body).at("id").get<std::string>();
    }
    core::Image flat(128, 128, 4);
    for (float& v : flat.data) v = 0.25f;
    const core::Image noise = test::white_noise(128, 128, 4, 9); // incompressible: over 40 kB
    const httplib::MultipartFormDataItems form = {
        {"textons", ids, "", ""},
        {"weights", io::encode_image_memory(flat, io::Encoding::png8).value(), "w.png",
         "image/png"},
        {"weights2", io::encode_image_memory(noise, io::Encoding::png8).value(), "w2.png",
         "image/png"}};
    auto r = c.Post("/v1/splats", form);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 507) << r->body;
    EXPECT_EQ(files_in(data + "/splats"), 0);
    EXPECT_EQ(c.Get("/healthz")->status, 200);
}

// A mix whose mask fits and whose levels do not: 507, and the mask is not left behind.
TEST(Store, AMixTheDiskCannotHoldLeavesNoFile) {
    const std::string data = fresh_dir("store-full-mix");
    ServerProcess server(data, {}, 40'000);
    auto c = server.client();
    std::vector<std::string> ids;
    for (const char* name : {"etr_sand01.png", "etr_pebbles04.png"}) {
        const std::string tiny = tiny_exemplar(name);
        auto r = c.Post("/v1/textons?size=32&iterations=5", tiny, "image/png");
        ASSERT_TRUE(r);
        ASSERT_EQ(r->status, 201) << r->body;
        ids.push_back(json::parse(r->body).at("id"));
    }
    core::Image mask(16, 16, 1);
    for (int x = 0; x < 16; ++x)
        for (int y = 0; y < 16; ++y) mask.at(0, x, y) = x < 8 ? 0.0f : 1.0f;
    // 12 levels of 32 x 32 RGB floats: about 150 kB, over the 40 kB a file may hold here.
    auto r = c.Post(("/v1/mixes?u=" + ids[0] + "&v=" + ids[1] + "&levels=12").c_str(),
                    io::encode_image_memory(mask, io::Encoding::png8).value(), "image/png");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 507) << r->body;
    EXPECT_EQ(files_in(data + "/mixes"), 0);
    EXPECT_EQ(c.Get("/healthz")->status, 200);
}

TEST(Store, SameTileSameBytesAndEtagAfterARestart) {
    const std::string data = fresh_dir("store-restart");
    std::string id, body, etag;
    const std::string tile = "/tiles/4/-123456789/987654321.png?seed=77&mni=12.5";
    {
        ServerProcess server(data);
        auto c = server.client();
        id = upload(c, "etr_floor01.png", "?size=24&iterations=10");
        auto res = c.Get(("/v1/textons/" + id + tile).c_str());
        ASSERT_EQ(res->status, 200);
        body = res->body;
        etag = res->get_header_value("ETag");
        ASSERT_EQ(server.terminate(10000), 0);
    }
    ServerProcess again(data);
    auto c = again.client();
    auto res = c.Get(("/v1/textons/" + id + tile).c_str());
    ASSERT_EQ(res->status, 200);
    EXPECT_EQ(res->get_header_value("ETag"), etag);
    EXPECT_EQ(res->body, body);
    EXPECT_EQ(c.Get(("/v1/textons/" + id + tile).c_str(), {{"If-None-Match", etag}})->status, 304);
}

// `textond analyze -o` and an upload both run TextonService::analyse and write one file, byte for
// byte; the upload's provenance (created, timings) is kept beside it and survives a restart.
TEST(Store, CliAndUploadWriteTheSameTextonFileAndProvenanceSurvivesARestart) {
    const std::string data = fresh_dir("store-provenance");
    const std::string cli_file = temp_path("cli-texton.exr");
    const RunResult cli = run("analyze " + exemplar_path("etr_floor01.png") +
                              " --size 24 --iterations 10 -o " + cli_file);
    ASSERT_EQ(cli.code, 0) << cli.err;
    std::string id, served, created;
    {
        ServerProcess server(data);
        auto c = server.client();
        id = upload(c, "etr_floor01.png", "?size=24&iterations=10");
        EXPECT_EQ(json::parse(cli.out).at("id"), id);
        auto file = c.Get(("/v1/textons/" + id + "/texton.exr").c_str());
        ASSERT_EQ(file->status, 200);
        served = file->body;
        const json meta = json::parse(c.Get(("/v1/textons/" + id).c_str())->body);
        created = meta.at("created");
        EXPECT_GT(meta.at("timings_ms").at("total").get<double>(), 0.0);
        ASSERT_EQ(server.terminate(10000), 0);
    }
    EXPECT_EQ(served, read_file(cli_file));
    EXPECT_EQ(read_file(data + "/textons/" + id + ".exr"), served);

    ServerProcess again(data);
    auto c = again.client();
    const json meta = json::parse(c.Get(("/v1/textons/" + id).c_str())->body);
    EXPECT_EQ(meta.at("created"), created);
    EXPECT_GT(meta.at("analysis_ms").get<double>(), 0.0);
    // Deleting the texton deletes its provenance.
    ASSERT_EQ(c.Delete(("/v1/textons/" + id).c_str())->status, 204);
    EXPECT_EQ(files_in(data + "/provenance"), 0);
}

// A second server on a port in use is refused, as it says: cpp-httplib's own socket options
// (SO_REUSEPORT) had let it bind too, and the kernel split the connections between the two.
TEST(Serve, ASecondServerOnAPortInUseIsRefused) {
    ServerProcess first(fresh_dir("serve-port-first"));
    const std::string command = std::string("timeout 20 ") + TEXTOND_BINARY + " serve --port " +
                                std::to_string(first.port()) + " --data " +
                                fresh_dir("serve-port-second") + " --backend cpu 2>&1";
    FILE* p = ::popen(command.c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::string out;
    char buf[256];
    while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
    const int status = ::pclose(p);
    ASSERT_TRUE(WIFEXITED(status)) << out;
    EXPECT_EQ(WEXITSTATUS(status), 1) << out; // 124: it listened until timeout killed it
    EXPECT_NE(out.find("cannot listen on 127.0.0.1:" + std::to_string(first.port())),
              std::string::npos)
        << out;
    EXPECT_EQ(first.client().Get("/healthz")->status, 200);
}

TEST(Serve, EnvironmentConfiguresAndFlagsWin) {
    // TEXTOND_API_KEY guards writes; TEXTOND_MAX_REGION_PIXELS is overridden by its flag.
    ::setenv("TEXTOND_API_KEY", "from-env", 1);
    ::setenv("TEXTOND_MAX_REGION_PIXELS", "100", 1);
    ServerProcess server(fresh_dir("serve-env"), {"--max-region-pixels", "300000"});
    ::unsetenv("TEXTOND_API_KEY");
    ::unsetenv("TEXTOND_MAX_REGION_PIXELS");
    auto c = server.client();
    const std::string body = read_file(exemplar_path("etr_sand01.png"));
    EXPECT_EQ(c.Post("/v1/textons?size=16&iterations=5", body, "image/png")->status, 401);
    auto ok = c.Post("/v1/textons?size=16&iterations=5", {{"Authorization", "Bearer from-env"}},
                     body, "image/png");
    ASSERT_TRUE(ok);
    ASSERT_EQ(ok->status, 201);
    const std::string id = json::parse(ok->body).at("id");
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/region.png?w=500&h=500").c_str())->status, 200);
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/region.png?w=600&h=600").c_str())->status, 400);
}

} // namespace
} // namespace textond::test
