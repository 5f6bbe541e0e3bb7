// Replicas sharing one Redis (`serve --store redis://...`), on real processes: a texton uploaded
// to one is served by the other with the same bytes; concurrent uploads of one exemplar store it
// once; Redis stopped mid-run costs uploads (503) but not the tiles of textons held locally, and
// coming back needs no restart; a damaged value in Redis is never served; deletes reach every
// replica; a flushed Redis is refilled by the replicas.
#include "server/app/job_board.h"
#include "server/io/image_io.h"
#include "server/io/sha256.h"
#include "server/store/redis_store.h"
#include "server/store/shared_objects.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <set>
#include <sstream>
#include <thread>
#include <unistd.h>

namespace textond::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::vector<std::string> replica_args(const RedisProcess& redis) {
    return {"--store", redis.url(), "--store-recheck-s", "1", "--store-timeout-ms", "500"};
}

httplib::Result get(const ServerProcess& s, const std::string& path) {
    auto c = s.client();
    return c.Get(path.c_str());
}

// A mix of u and v (2 levels) and a splat of them (random 8 x 8 weights), made through `c`: their
// ids, or empty ones after a failed assertion.
std::pair<std::string, std::string> mix_and_splat(httplib::Client& c, const std::string& u,
                                                  const std::string& v) {
    auto mix = c.Post(("/v1/mixes?u=" + u + "&v=" + v + "&levels=2").c_str());
    EXPECT_TRUE(mix && mix->status == 201) << (mix ? mix->body : "no answer");
    const std::string weights =
        io::encode_image_memory(test::white_noise(8, 8, 3, 3), io::Encoding::png8).value();
    const httplib::MultipartFormDataItems form = {{"textons", u + "," + v, "", ""},
                                                  {"weights", weights, "w.png", "image/png"}};
    auto splat = c.Post("/v1/splats", form);
    EXPECT_TRUE(splat && splat->status == 201) << (splat ? splat->body : "no answer");
    if (!mix || mix->status != 201 || !splat || splat->status != 201) return {};
    return {json::parse(mix->body).at("id"), json::parse(splat->body).at("id")};
}

int status_of(const ServerProcess& s, const std::string& path) {
    auto r = get(s, path);
    return r ? r->status : -1;
}

std::string texton_key(const std::string& id) {
    return "textond:v1:texton:" + id;
}

// Polls until `check` holds or `seconds` pass.
template <class F> bool eventually(F check, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
        if (check()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return check();
}

// Resident memory of a process, MB (/proc/PID/status).
double rss_mb(int pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(in, line);)
        if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return -1;
}

double metric(const ServerProcess& s, const std::string& series) {
    const std::string text = get(s, "/metrics")->body;
    const auto at = text.find("\n" + series + " ");
    if (at == std::string::npos) return -1;
    return std::stod(text.substr(at + series.size() + 2));
}

TEST(RedisUrl, ParsesTheFormsWeDocument) {
    auto a = store::parse_redis_url("redis://cache.internal");
    ASSERT_TRUE(a);
    EXPECT_EQ(a.value().host, "cache.internal");
    EXPECT_EQ(a.value().port, 6379);
    EXPECT_EQ(a.value().db, 0);
    auto b = store::parse_redis_url("redis://user:s3cr@t@10.0.0.5:6380/2");
    ASSERT_TRUE(b);
    EXPECT_EQ(b.value().user, "user");
    EXPECT_EQ(b.value().password, "s3cr@t");
    EXPECT_EQ(b.value().host, "10.0.0.5");
    EXPECT_EQ(b.value().port, 6380);
    EXPECT_EQ(b.value().db, 2);
    auto c = store::parse_redis_url("redis://:pw@[::1]:7000/");
    ASSERT_TRUE(c);
    EXPECT_EQ(c.value().host, "::1");
    EXPECT_EQ(c.value().port, 7000);
    EXPECT_EQ(c.value().password, "pw");
    EXPECT_TRUE(c.value().user.empty());
    for (const char* bad :
         {"http://x:6379", "redis://", "redis://:6379", "redis://h:0", "redis://h:65536",
          "redis://h:12ab", "redis://h/db", "redis://h/-1", "redis://pw@h", "redis://[::1"}) {
        SCOPED_TRACE(bad);
        auto r = store::parse_redis_url(bad);
        ASSERT_FALSE(r);
        EXPECT_NE(r.error().message.find("redis://"), std::string::npos) << r.error().message;
    }
}

TEST(SharedStore, ATextonUploadedToOneReplicaIsServedByTheOtherWithTheSameBytes) {
    RedisProcess redis(fresh_dir("shared-a-redis"));
    const std::string dir_b = fresh_dir("shared-a-2");
    ServerProcess a(fresh_dir("shared-a-1"), replica_args(redis));
    ServerProcess b(dir_b, replica_args(redis));
    auto ca = a.client();
    int status = 0;
    const std::string id = upload(ca, "etr_sand01.png", "?size=32", &status);
    EXPECT_EQ(status, 201);

    const json ma = json::parse(get(a, "/v1/textons/" + id)->body);
    const json mb = json::parse(get(b, "/v1/textons/" + id)->body);
    EXPECT_EQ(ma, mb);
    for (const std::string tile : {"tiles/0/0/0.png", "tiles/2/-3/7.png16", "tiles/-1/5/5.exr",
                                   "tiles/0/-9007199254740992/12.png"}) {
        SCOPED_TRACE(tile);
        auto ta = get(a, "/v1/textons/" + id + "/" + tile);
        auto tb = get(b, "/v1/textons/" + id + "/" + tile);
        ASSERT_EQ(ta->status, 200);
        ASSERT_EQ(tb->status, 200);
        EXPECT_TRUE(ta->body == tb->body);
        EXPECT_EQ(ta->get_header_value("ETag"), tb->get_header_value("ETag"));
    }
    for (const std::string file : {"texton.exr", "exemplar.png"})
        EXPECT_TRUE(get(a, "/v1/textons/" + id + "/" + file)->body ==
                    get(b, "/v1/textons/" + id + "/" + file)->body)
            << file;
    // Kept by b: its data directory is a read-through cache.
    EXPECT_TRUE(fs::exists(fs::path(dir_b) / "textons" / (id + ".exr")));
    // The same exemplar uploaded to b is known at once: 200, and b runs no analysis.
    auto cb = b.client();
    upload(cb, "etr_sand01.png", "?size=32", &status);
    EXPECT_EQ(status, 200);
    EXPECT_EQ(metric(b, "textond_analyses_total{result=\"ok\"}"), 0);
    const json list = json::parse(get(b, "/v1/textons")->body);
    ASSERT_EQ(list["items"].size(), 1u);
    EXPECT_EQ(list["total"], 1);
    EXPECT_EQ(metric(a, "textond_shared_store_up"), 1);
}

TEST(SharedStore, ConcurrentUploadsOfOneExemplarToTwoReplicasStoreOneTexton) {
    RedisProcess redis(fresh_dir("shared-b-redis"));
    ServerProcess a(fresh_dir("shared-b-1"), replica_args(redis));
    ServerProcess b(fresh_dir("shared-b-2"), replica_args(redis));
    const std::string body = read_file(exemplar_path("skimage_grass.png"));
    for (int seed = 1; seed <= 4; ++seed) {
        SCOPED_TRACE(seed);
        const std::string path = "/v1/textons?size=32&seed=" + std::to_string(seed);
        std::promise<void> go;
        std::shared_future<void> start = go.get_future().share();
        auto post = [&](const ServerProcess& s) {
            return std::async(std::launch::async, [&, start] {
                auto c = s.client();
                start.wait();
                auto r = c.Post(path.c_str(), body, "image/png");
                return r ? std::make_pair(r->status, r->body) : std::make_pair(-1, std::string());
            });
        };
        auto fa = post(a);
        auto fb = post(b);
        go.set_value();
        const auto [sa, ba] = fa.get();
        const auto [sb, bb] = fb.get();
        ASSERT_TRUE((sa == 201 && sb == 200) || (sa == 200 && sb == 201)) << sa << " " << sb;
        const std::string id = json::parse(ba)["id"];
        EXPECT_EQ(json::parse(bb)["id"], id);
        // One stored texton: the same metadata (creation time included) and file on both.
        EXPECT_EQ(json::parse(ba), json::parse(bb));
        EXPECT_TRUE(get(a, "/v1/textons/" + id + "/texton.exr")->body ==
                    get(b, "/v1/textons/" + id + "/texton.exr")->body);
        EXPECT_EQ(redis.cli({"ZCARD", "textond:v1:ids"}), std::to_string(seed) + "\n");
    }
}

TEST(SharedStore, RedisDownCostsUploadsNotCachedTilesAndComingBackNeedsNoRestart) {
    RedisProcess redis(fresh_dir("shared-c-redis"));
    const std::string dir_b = fresh_dir("shared-c-2");
    ServerProcess a(fresh_dir("shared-c-1"), replica_args(redis));
    auto b = std::make_unique<ServerProcess>(dir_b, replica_args(redis));
    auto ca = a.client();
    const std::string id = upload(ca, "etr_sand01.png", "?size=32");
    ASSERT_EQ(status_of(*b, "/v1/textons/" + id), 200); // b holds it now

    redis.stop();
    // Uploads: 503 with a clear error, before any analysis is spent.
    const std::string body = read_file(exemplar_path("etr_pave02.png"));
    auto up = ca.Post("/v1/textons?size=32", body, "image/png");
    ASSERT_TRUE(up);
    EXPECT_EQ(up->status, 503);
    EXPECT_EQ(json::parse(up->body)["error"]["code"], "store_unavailable");
    EXPECT_NE(up->body.find(redis.url()), std::string::npos) << up->body;
    EXPECT_EQ(up->get_header_value("Retry-After"), "1");
    EXPECT_EQ(metric(a, "textond_analyses_total{result=\"ok\"}"), 1); // the first upload only
    // Tiles of textons held locally keep coming, freshly rendered ones included, also after the
    // recheck interval and from a replica restarted while Redis is down.
    std::this_thread::sleep_for(std::chrono::milliseconds(1200));
    for (int x = 0; x < 4; ++x) {
        EXPECT_EQ(status_of(a, "/v1/textons/" + id + "/tiles/0/" + std::to_string(x) + "/1.png"),
                  200);
        EXPECT_EQ(status_of(*b, "/v1/textons/" + id + "/tiles/1/" + std::to_string(x) + "/1.png"),
                  200);
    }
    b.reset();
    b = std::make_unique<ServerProcess>(dir_b, replica_args(redis));
    EXPECT_EQ(status_of(*b, "/v1/textons/" + id + "/tiles/3/3/3.png"), 200);
    EXPECT_EQ(status_of(*b, "/v1/textons/" + id), 200);
    // What only Redis could answer is 503, not a false 404.
    EXPECT_EQ(status_of(*b, "/v1/textons/" + std::string(64, 'a')), 503);
    EXPECT_EQ(status_of(*b, "/v1/textons"), 503);
    // Readiness: still ready (it serves what it holds), degraded, and says why.
    auto ready = get(a, "/readyz");
    EXPECT_EQ(ready->status, 200);
    const json rj = json::parse(ready->body);
    EXPECT_TRUE(rj["degraded"].get<bool>());
    EXPECT_FALSE(rj["shared_store"]["up"].get<bool>());
    EXPECT_NE(rj["shared_store"]["error"].get<std::string>().find("unavailable"),
              std::string::npos);
    EXPECT_EQ(metric(a, "textond_shared_store_up"), 0);

    redis.start(); // same port and data
    EXPECT_TRUE(eventually(
        [&] {
            auto r = ca.Post("/v1/textons?size=32", body, "image/png");
            return r && r->status == 201;
        },
        10.0));
    EXPECT_FALSE(json::parse(get(a, "/readyz")->body)["degraded"].get<bool>());
    // b fails fast for a second after its last failure, then finds Redis again by itself.
    EXPECT_TRUE(eventually([&] { return status_of(*b, "/v1/textons") == 200; }, 3.0));
    EXPECT_EQ(json::parse(get(*b, "/v1/textons")->body)["total"], 2);
    EXPECT_EQ(metric(*b, "textond_shared_store_up"), 1);
}

TEST(SharedStore, ADamagedValueInRedisIsNeverServed) {
    RedisProcess redis(fresh_dir("shared-d-redis"));
    // a rechecks (and would repair the entries from its copies) only every ten minutes here.
    ServerProcess a(fresh_dir("shared-d-1"), {"--store", redis.url(), "--store-recheck-s", "600",
                                              "--store-timeout-ms", "500"});
    const std::string dir_b = fresh_dir("shared-d-2");
    ServerProcess b(dir_b, replica_args(redis));
    auto ca = a.client();
    const std::string id1 = upload(ca, "etr_sand01.png", "?size=32");
    const std::string id2 = upload(ca, "etr_pave02.png", "?size=32");
    const std::string file = get(a, "/v1/textons/" + id1 + "/texton.exr")->body;
    ASSERT_GT(file.size(), 1000u);

    // id1: a half-written file (its checksum field names the whole one).
    redis.cli({"-x", "HSET", texton_key(id1), "file"}, file.substr(0, file.size() / 2));
    // id2: another texton's file under its name, with a matching checksum: the metadata check
    // (id = key) refuses it.
    redis.cli({"-x", "HSET", texton_key(id2), "file"}, file);
    redis.cli({"HSET", texton_key(id2), "sha256", io::sha256_hex(file)});
    for (const std::string& id : {id1, id2}) {
        SCOPED_TRACE(id);
        auto meta = get(b, "/v1/textons/" + id);
        EXPECT_EQ(meta->status, 500);
        EXPECT_EQ(json::parse(meta->body)["error"]["code"], "storage_error");
        EXPECT_EQ(status_of(b, "/v1/textons/" + id + "/tiles/0/0/0.png"), 500);
        EXPECT_FALSE(fs::exists(fs::path(dir_b) / "textons" / (id + ".exr")));
    }
    // a, which holds good copies, keeps serving them.
    EXPECT_EQ(status_of(a, "/v1/textons/" + id1 + "/tiles/0/0/0.png"), 200);
}

// Redis metadata is text: A's replaced by JSON naming C with a made-up RME. The replica holding a
// verified copy of A lists A as it is; one without lists neither A's forgery nor C twice.
TEST(SharedStore, TheListDoesNotTrustMetadataThatNamesAnotherId) {
    RedisProcess redis(fresh_dir("shared-l-redis"));
    ServerProcess a(fresh_dir("shared-l-1"), replica_args(redis));
    ServerProcess b(fresh_dir("shared-l-2"), replica_args(redis));
    auto ca = a.client();
    const std::string ida = upload(ca, "etr_sand01.png", "?size=32");
    const std::string idc = upload(ca, "etr_pave02.png", "?size=32");
    const double rme_a = json::parse(get(a, "/v1/textons/" + ida)->body).at("rme");
    json forged = json::parse(redis.cli({"HGET", texton_key(idc), "meta"}));
    forged["rme"] = 0.0001;
    redis.cli({"-x", "HSET", texton_key(ida), "meta"}, forged.dump());
    auto ids_of = [](const ServerProcess& s) {
        std::multiset<std::string> ids;
        const json list = json::parse(get(s, "/v1/textons")->body);
        for (const auto& item : list.at("items")) ids.insert(item.at("id").get<std::string>());
        return ids;
    };
    EXPECT_EQ(ids_of(a), (std::multiset<std::string>{ida, idc}));
    const json listed = json::parse(get(a, "/v1/textons")->body);
    for (const auto& item : listed.at("items")) {
        if (item.at("id") == ida) {
            EXPECT_EQ(item.at("rme").get<double>(), rme_a);
        }
    }
    EXPECT_EQ(ids_of(b).count(idc), 1u) << "C listed twice";
}

// A full Redis (maxmemory, noeviction) refuses writes: the upload that finds out answers 503,
// readiness says degraded and the metric 0, and the next upload is refused before its analysis.
// A damaged entry is rewritten by a replica that holds a verified copy.
TEST(SharedStore, AFullRedisIsReportedAndADamagedEntryIsRepaired) {
    RedisProcess redis(fresh_dir("shared-o-redis"));
    ServerProcess a(fresh_dir("shared-o-1"), replica_args(redis));
    auto ca = a.client();
    const std::string id = upload(ca, "etr_sand01.png", "?size=16");
    const std::string file = get(a, "/v1/textons/" + id + "/texton.exr")->body;
    // Damaged: half the file under the whole one's checksum. a repairs it at its next recheck.
    redis.cli({"-x", "HSET", texton_key(id), "file"}, file.substr(0, file.size() / 2));
    EXPECT_TRUE(eventually(
        [&] {
            return redis.cli({"HSTRLEN", texton_key(id), "file"}) ==
                   std::to_string(file.size()) + "\n";
        },
        5.0))
        << "not repaired";
    ServerProcess b(fresh_dir("shared-o-2"), replica_args(redis));
    EXPECT_EQ(status_of(b, "/v1/textons/" + id + "/tiles/0/0/0.png"), 200);

    redis.cli({"CONFIG", "SET", "maxmemory-policy", "noeviction"});
    redis.cli({"CONFIG", "SET", "maxmemory", "1"});
    auto first =
        ca.Post("/v1/textons?size=16", read_file(exemplar_path("etr_pave02.png")), "image/png");
    ASSERT_TRUE(first);
    EXPECT_EQ(first->status, 503) << first->body;
    const json ready = json::parse(get(a, "/readyz")->body);
    EXPECT_TRUE(ready.at("degraded").get<bool>()) << ready.dump();
    EXPECT_EQ(metric(a, "textond_shared_store_up"), 0.0);
    auto again =
        ca.Post("/v1/textons?size=16", read_file(exemplar_path("etr_pebbles04.png")), "image/png");
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 503);
    EXPECT_NE(again->body.find("refuses writes"), std::string::npos) << again->body;
}

// An evicting Redis would drop textons: readiness says degraded and the metric is 0 before any
// write fails, and both recover when the policy is set back.
TEST(SharedStore, AnEvictingRedisIsReportedBeforeAWriteFails) {
    RedisProcess redis(fresh_dir("shared-ev-redis"));
    ServerProcess a(fresh_dir("shared-ev-1"), replica_args(redis));
    EXPECT_EQ(metric(a, "textond_shared_store_up"), 1.0);
    redis.cli({"CONFIG", "SET", "maxmemory-policy", "allkeys-lru"});
    const json ready = json::parse(get(a, "/readyz")->body);
    EXPECT_TRUE(ready.at("degraded").get<bool>()) << ready.dump();
    EXPECT_NE(ready.at("shared_store").at("error").get<std::string>().find("evicts"),
              std::string::npos)
        << ready.dump();
    EXPECT_EQ(metric(a, "textond_shared_store_up"), 0.0);
    redis.cli({"CONFIG", "SET", "maxmemory-policy", "noeviction"});
    EXPECT_FALSE(json::parse(get(a, "/readyz")->body).at("degraded").get<bool>());
    EXPECT_EQ(metric(a, "textond_shared_store_up"), 1.0);
}

// A value larger than any texton's (100 MB in `file`) is refused unread: b's memory does not grow
// by it on each request, and the store stays up for every other texton.
TEST(SharedStore, AHugeValueInRedisIsRefusedUnreadAndTheStoreStaysUp) {
    RedisProcess redis(fresh_dir("shared-h-redis"));
    std::string id1, id2;
    { // the analysing replica stops (it would repair the entry from its copy)
        ServerProcess a(fresh_dir("shared-h-1"), replica_args(redis));
        auto ca = a.client();
        id1 = upload(ca, "etr_sand01.png", "?size=32");
        id2 = upload(ca, "etr_pave02.png", "?size=32");
    }
    ServerProcess b(fresh_dir("shared-h-2"), replica_args(redis));
    const std::string huge(100u << 20, 'x');
    redis.cli({"-x", "HSET", texton_key(id1), "file"}, huge);
    const double before = rss_mb(b.pid());
    for (int i = 0; i < 4; ++i) {
        auto meta = get(b, "/v1/textons/" + id1);
        ASSERT_TRUE(meta);
        EXPECT_EQ(meta->status, 500);
        EXPECT_NE(meta->body.find("not read"), std::string::npos) << meta->body;
    }
    EXPECT_LT(rss_mb(b.pid()) - before, 50.0) << "the value was read";
    // The store is up: the other texton reaches b, and readiness is not degraded.
    EXPECT_EQ(status_of(b, "/v1/textons/" + id2 + "/tiles/0/0/0.png"), 200);
    EXPECT_EQ(metric(b, "textond_shared_store_up"), 1.0);
}

// Every value's size is checked before it is read, against what it holds. A 100
// MB `meta` under three ids is skipped unread by the list; a 100 MB `exemplar` (under the 112 MiB
// cap of any exemplar, but over what this exemplar's PNG can hold) is refused unread by
// eight concurrent tile requests; and memory does not stay up afterwards.
TEST(SharedStore, EveryValueIsBoundedByWhatItHoldsBeforeItIsRead) {
    RedisProcess redis(fresh_dir("shared-v-redis"));
    std::vector<std::string> ids;
    {
        ServerProcess a(fresh_dir("shared-v-1"), replica_args(redis));
        auto ca = a.client();
        for (const char* name :
             {"etr_sand01.png", "etr_pave02.png", "etr_pebbles04.png", "etr_floor01.png"})
            ids.push_back(upload(ca, name, "?size=16&iterations=5"));
    }
    ServerProcess b(fresh_dir("shared-v-2"), replica_args(redis));
    const double idle = rss_mb(b.pid());
    const std::string huge(100u << 20, '{');
    for (int i = 0; i < 3; ++i) redis.cli({"-x", "HSET", texton_key(ids[i]), "meta"}, huge);
    auto list = get(b, "/v1/textons");
    ASSERT_TRUE(list);
    EXPECT_EQ(list->status, 200) << list->body.substr(0, 300);
    EXPECT_EQ(json::parse(list->body).at("items").size(), 1u) << "the huge metadata was listed";
    EXPECT_LT(rss_mb(b.pid()) - idle, 50.0) << "the list read the huge metadata";

    const std::string victim = ids[3];
    const std::string bigpng(100u << 20, 'p');
    redis.cli({"-x", "HSET", texton_key(victim), "exemplar"}, bigpng);
    redis.cli({"HSET", texton_key(victim), "exemplar_sha256", io::sha256_hex(bigpng)});
    double peak = 0;
    std::atomic<bool> sampling{true};
    std::thread sampler([&] {
        while (sampling) {
            peak = std::max(peak, rss_mb(b.pid()));
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    });
    std::vector<std::future<int>> tiles;
    for (int i = 0; i < 8; ++i)
        tiles.push_back(std::async(std::launch::async, [&, i] {
            return status_of(b,
                             "/v1/textons/" + victim + "/tiles/0/0/" + std::to_string(i) + ".png");
        }));
    for (auto& t : tiles) EXPECT_EQ(t.get(), 500);
    sampling = false;
    sampler.join();
    EXPECT_LT(peak - idle, 60.0) << "the exemplar was read";
    auto meta = get(b, "/v1/textons/" + victim);
    ASSERT_TRUE(meta);
    EXPECT_EQ(meta->status, 500);
    EXPECT_NE(meta->body.find("not read"), std::string::npos) << meta->body;
    EXPECT_EQ(metric(b, "textond_shared_store_up"), 1.0);
}

// The exemplar a texton's size allows: an 8-bit PNG of four channels stored uncompressed at worst,
// never more than the cap of any exemplar.
TEST(RedisStore, ExemplarCapFitsWhatTheExemplarHolds) {
    EXPECT_EQ(store::RedisStore::exemplar_cap(0, 64), 0);
    EXPECT_GE(store::RedisStore::exemplar_cap(64, 64), 64 * 64 * 4 + 64);
    EXPECT_LT(store::RedisStore::exemplar_cap(64, 64), 100 << 10);
    EXPECT_GE(store::RedisStore::exemplar_cap(4096, 4096), 4096LL * 4096 * 3);
    EXPECT_EQ(store::RedisStore::exemplar_cap(1 << 20, 1 << 20),
              store::RedisStore::kMaxExemplarBytes);
}

TEST(SharedStore, DeletesReachEveryReplicaAndAFlushedRedisIsRefilled) {
    RedisProcess redis(fresh_dir("shared-e-redis"));
    ServerProcess a(fresh_dir("shared-e-1"), replica_args(redis));
    const std::string dir_b = fresh_dir("shared-e-2");
    ServerProcess b(dir_b, replica_args(redis));
    auto ca = a.client();
    auto cb = b.client();
    const std::string id = upload(ca, "etr_sand01.png", "?size=32");
    ASSERT_EQ(status_of(b, "/v1/textons/" + id + "/tiles/0/0/0.png"), 200);
    // b fetched the texton from Redis with a's provenance, kept beside its copy.
    const fs::path provenance_b = fs::path(dir_b) / "provenance" / (id + ".json");
    EXPECT_TRUE(fs::exists(provenance_b));
    ASSERT_EQ(ca.Delete(("/v1/textons/" + id).c_str())->status, 204);
    EXPECT_EQ(status_of(a, "/v1/textons/" + id), 404);
    // b drops its copy at its next recheck (1 s here).
    EXPECT_TRUE(eventually([&] { return status_of(b, "/v1/textons/" + id) == 404; }, 3.0));
    EXPECT_EQ(status_of(b, "/v1/textons/" + id + "/tiles/0/0/0.png"), 404);
    EXPECT_FALSE(fs::exists(provenance_b)); // nothing of the deleted copy is left
    // Uploaded again (to b): stored again, and a finds it.
    int status = 0;
    upload(cb, "etr_sand01.png", "?size=32", &status);
    EXPECT_EQ(status, 201);
    EXPECT_EQ(status_of(a, "/v1/textons/" + id), 200);

    // Redis loses everything; the replicas write back what they hold when they recheck it. A
    // replica may do so before the next command here (it did under load), so the flush is seen
    // on a key no replica holds.
    redis.cli({"SET", "flush-witness", "1"});
    redis.cli({"FLUSHALL"});
    EXPECT_EQ(redis.cli({"EXISTS", "flush-witness"}), "0\n");
    EXPECT_TRUE(eventually(
        [&] {
            status_of(a, "/v1/textons/" + id);
            return redis.cli({"EXISTS", texton_key(id)}) == "1\n";
        },
        3.0));
    ServerProcess c(fresh_dir("shared-e-3"), replica_args(redis));
    EXPECT_EQ(status_of(c, "/v1/textons/" + id + "/tiles/0/0/0.png"), 200);
    auto ea = get(a, "/v1/textons/" + id + "/exemplar.png");
    auto ec = get(c, "/v1/textons/" + id + "/exemplar.png");
    EXPECT_EQ(ea->status, 200);
    EXPECT_EQ(ec->status, 200);
    EXPECT_TRUE(ea->body == ec->body);
}

// After FLUSHALL every texton a replica holds is written back, whether or not anyone asks for it
// (only an id that reached a replica used to be), so the list is whole again and a fresh replica
// finds each of them.
TEST(SharedStore, AFlushedRedisGetsBackEveryHeldTextonUnasked) {
    RedisProcess redis(fresh_dir("shared-f-redis"));
    ServerProcess a(fresh_dir("shared-f-1"), replica_args(redis));
    auto ca = a.client();
    const std::vector<std::string> ids = {upload(ca, "etr_sand01.png", "?size=16"),
                                          upload(ca, "etr_pave02.png", "?size=16"),
                                          upload(ca, "etr_pebbles04.png", "?size=16")};
    redis.cli({"FLUSHALL"});
    EXPECT_TRUE(eventually(
        [&] {
            for (const auto& id : ids)
                if (redis.cli({"EXISTS", texton_key(id)}) != "1\n") return false;
            return true;
        },
        5.0))
        << "not every held texton was written back";
    ServerProcess c(fresh_dir("shared-f-3"), replica_args(redis));
    EXPECT_EQ(json::parse(get(c, "/v1/textons")->body).at("total"), 3);
    for (const auto& id : ids)
        EXPECT_EQ(status_of(c, "/v1/textons/" + id + "/tiles/0/0/0.png"), 200);
}

// A repair runs after the replica saw the texton present; a delete landing between must win. The
// race reduced to its order: present, then deleted (tombstone), then the repair's write. It had
// brought the texton back beside its tombstone and out of the list, served by every replica.
TEST(RedisStore, ARepairAfterADeleteDoesNotBringTheTextonBack) {
    RedisProcess redis(fresh_dir("shared-r-redis"));
    store::RedisStore shared(store::parse_redis_url(redis.url()).value(),
                             std::chrono::milliseconds(2000));
    const std::string id(64, 'a');
    ASSERT_TRUE(shared.put(id, "file bytes", "{}", "").value());
    ASSERT_EQ(shared.presence(id).value(), store::RedisStore::Presence::present);
    // Damaged in place: the repair rewrites it while it is there.
    redis.cli({"HSET", texton_key(id), "file", "damaged"});
    EXPECT_TRUE(shared.repair_if_differs(id, "file bytes", "{}", "").value());
    EXPECT_EQ(redis.cli({"HGET", texton_key(id), "file"}), "file bytes\n");
    ASSERT_TRUE(shared.remove(id).value());
    EXPECT_FALSE(shared.repair_if_differs(id, "file bytes", "{}", "").value());
    EXPECT_EQ(redis.cli({"EXISTS", texton_key(id)}), "0\n");
    EXPECT_EQ(shared.presence(id).value(), store::RedisStore::Presence::deleted);
}

// A write-back (a replica's copy of what the store lost) never lands over a tombstone: a delete
// between the replica's look and its write had been undone. An upload clears the tombstone.
TEST(RedisStore, AWriteBackNeverUndoesADelete) {
    RedisProcess redis(fresh_dir("shared-w-redis"));
    store::RedisStore shared(store::parse_redis_url(redis.url()).value(),
                             std::chrono::milliseconds(2000));
    const std::string id(64, 'd');
    ASSERT_TRUE(shared.put(id, "file", "{}", "").value());
    ASSERT_TRUE(shared.remove(id).value());
    EXPECT_FALSE(shared.put(id, "file", "{}", "", /*write_back=*/true).value());
    EXPECT_EQ(shared.presence(id).value(), store::RedisStore::Presence::deleted);
    EXPECT_TRUE(shared.put(id, "file", "{}", "").value()); // uploaded again
    EXPECT_EQ(shared.presence(id).value(), store::RedisStore::Presence::present);
    const store::RedisStore::Files files = {{".json", "{}"}};
    ASSERT_TRUE(shared.put_object("mix", id, files).value());
    ASSERT_TRUE(shared.remove_object("mix", id).value());
    EXPECT_FALSE(shared.put_object("mix", id, files, /*write_back=*/true).value());
    EXPECT_EQ(shared.object_presence("mix", id).value(), store::RedisStore::Presence::deleted);
    // A texton whose hash has no file at all is damaged, not "changed while read" (503 forever).
    redis.cli(
        {"HSET", texton_key(std::string(64, 'e')), "meta", "{}", "sha256", std::string(64, '0')});
    auto got = shared.get(std::string(64, 'e'));
    ASSERT_FALSE(got);
    EXPECT_EQ(got.error().code, ErrorCode::io) << got.error().message;
}

// Between a creation's local files and its own publish, a write-back (a sweep, a request's
// recheck) stores nothing: it had stored the object first, and the creation answered 200.
TEST(SharedObjects, AWriteBackWaitsForACreationInFlight) {
    RedisProcess redis(fresh_dir("shared-c-redis"));
    store::RedisStore shared(store::parse_redis_url(redis.url()).value(),
                             std::chrono::milliseconds(2000));
    const std::string dir = fresh_dir("shared-c-dir");
    store::SharedObjects objects(&shared, "mix", dir, {{".json", 1 << 20}},
                                 std::chrono::milliseconds(3'600'000));
    const std::string id(64, 'f');
    {
        const store::InFlightIds::Mark creating(objects.creations(), id);
        std::ofstream(dir + "/" + id + ".json") << "{}";
        EXPECT_FALSE(objects.publish(id, /*write_back=*/true).value());
        EXPECT_EQ(redis.cli({"EXISTS", "textond:v1:mix:" + id}), "0\n");
        EXPECT_TRUE(objects.publish(id).value()); // the creation's own
    }
    ASSERT_TRUE(shared.remove_object("mix", id).value());
    redis.cli({"DEL", "textond:v1:deleted-mix:" + id}); // lost, as after a flush
    EXPECT_TRUE(objects.publish(id, /*write_back=*/true).value());
}

// --store-recheck-s 0 rechecks on every request; the sweeps had spun on it, a core each.
TEST(SharedStore, ARecheckIntervalOfZeroDoesNotSpin) {
    RedisProcess redis(fresh_dir("shared-z-redis"));
    ServerProcess a(fresh_dir("shared-z-1"), {"--store", redis.url(), "--store-recheck-s", "0"});
    auto cpu_s = [&] {
        std::ifstream in("/proc/" + std::to_string(a.pid()) + "/stat");
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::istringstream fields(text.substr(text.rfind(')') + 2));
        std::string f;
        std::vector<std::string> v;
        while (fields >> f) v.push_back(f);
        return (std::stod(v[11]) + std::stod(v[12])) / static_cast<double>(::sysconf(_SC_CLK_TCK));
    };
    std::this_thread::sleep_for(std::chrono::milliseconds(500)); // past its start-up
    const double before = cpu_s();
    std::this_thread::sleep_for(std::chrono::seconds(2));
    EXPECT_LT(cpu_s() - before, 0.3) << "CPU seconds in 2 s idle";
}

// Reads racing a writer that stores and deletes one value for 3 s: none may be called damaged (an
// io error), and at least one must find the value, or the race was not run. `read` says whether
// it found it.
template <class Churn, class Read> void expect_no_read_called_damaged(Churn churn_once, Read read) {
    std::atomic<bool> stop{false};
    std::thread churn([&] {
        while (!stop) churn_once();
    });
    int found = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (std::chrono::steady_clock::now() < end) {
        Result<bool> got = read();
        if (got && got.value()) ++found;
        if (!got && got.error().code == ErrorCode::io) {
            ADD_FAILURE() << "called damaged: " << got.error().message;
            break;
        }
    }
    stop = true;
    churn.join();
    EXPECT_GT(found, 0) << "the reader never found the value: the race was not run";
}

// A texton is read in several commands: deleted or stored again between them, it is not damage
// (it had been refused as "fails its file checksum", 500, and remembered for a minute).
TEST(RedisStore, AReadRacingDeletesAndUploadsIsNeverCalledDamaged) {
    RedisProcess redis(fresh_dir("shared-t-redis"));
    const auto address = store::parse_redis_url(redis.url()).value();
    store::RedisStore writer(address, std::chrono::milliseconds(2000));
    store::RedisStore reader(address, std::chrono::milliseconds(2000));
    const std::string id(64, 'b');
    const std::string file(200'000, 'f'); // long enough that a read spans a write
    expect_no_read_called_damaged(
        [&] {
            (void)writer.put(id, file, "{}", "");
            (void)writer.remove(id);
        },
        [&]() -> Result<bool> {
            auto got = reader.get(id);
            if (!got) return got.error();
            return got.value().has_value();
        });
}

// Splats and mixes too are written back after FLUSHALL by the replica that holds them, unasked
// (only one that was asked used to write back; another replica answered 404 meanwhile).
TEST(SharedStore, AFlushedRedisGetsBackEveryHeldSplatAndMixUnasked) {
    RedisProcess redis(fresh_dir("shared-g-redis"));
    ServerProcess a(fresh_dir("shared-g-1"), replica_args(redis));
    auto ca = a.client();
    const std::string u = upload(ca, "etr_sand01.png", "?size=16&iterations=5");
    const std::string v = upload(ca, "etr_pebbles04.png", "?size=16&iterations=5");
    const auto [mid, sid] = mix_and_splat(ca, u, v);
    ASSERT_FALSE(mid.empty());
    redis.cli({"FLUSHALL"});
    EXPECT_TRUE(eventually(
        [&] {
            return redis.cli({"EXISTS", "textond:v1:mix:" + mid}) == "1\n" &&
                   redis.cli({"EXISTS", "textond:v1:splat:" + sid}) == "1\n";
        },
        5.0))
        << "the mix and the splat were not written back";
    ServerProcess c(fresh_dir("shared-g-3"), replica_args(redis));
    EXPECT_EQ(status_of(c, "/v1/mixes/" + mid), 200);
    EXPECT_EQ(status_of(c, "/v1/splats/" + sid + "/tiles/0/0/0.png"), 200);
}

// Splats and mixes alike: their probe had read the field count, the sizes and the checksums in
// separate commands, so a delete and a new put between them refused a sound object.
TEST(RedisStore, AnObjectReadRacingDeletesAndPutsIsNeverCalledDamaged) {
    RedisProcess redis(fresh_dir("shared-u-redis"));
    const auto address = store::parse_redis_url(redis.url()).value();
    store::RedisStore writer(address, std::chrono::milliseconds(2000));
    store::RedisStore reader(address, std::chrono::milliseconds(2000));
    const std::string id(64, 'c');
    const store::RedisStore::Files files = {{".json", std::string(1000, 'j')},
                                            {".exr", std::string(200'000, 'e')}};
    const std::map<std::string, long long> caps = {{".json", 1 << 20}, {".exr", 1 << 20}};
    expect_no_read_called_damaged(
        [&] {
            (void)writer.put_object("mix", id, files);
            (void)writer.remove_object("mix", id);
        },
        [&]() -> Result<bool> {
            auto got = reader.get_object("mix", id, caps);
            if (!got) return got.error();
            if (got.value()) {
                EXPECT_TRUE(*got.value() == files);
            }
            return got.value().has_value();
        });
}

// A replica whose disk is full: a texton or mix it cannot copy from Redis answers 503 each time
// (the edge asks the next replica; it was 507, which nginx does not retry), never 500 "refused
// before" (its values are sound), and without this server's paths; an upload it cannot hold is
// not stored for the other replicas either.
TEST(SharedStore, AFullDiskOnOneReplicaRefusesNothingInTheSharedStore) {
    RedisProcess redis(fresh_dir("shared-d-redis"));
    ServerProcess a(fresh_dir("shared-d-1"), replica_args(redis));
    const std::string dir_b = fresh_dir("shared-d-2");
    ServerProcess b(dir_b, replica_args(redis), 40'000);
    auto ca = a.client();
    // Of 64 texels a side: a texton file and the mix's levels are larger than b may write.
    const std::string id = upload(ca, "etr_sand01.png", "?size=64&iterations=5");
    const std::string v = upload(ca, "etr_pebbles04.png", "?size=64&iterations=5");
    auto mix = ca.Post(("/v1/mixes?u=" + id + "&v=" + v + "&levels=2").c_str());
    ASSERT_TRUE(mix);
    ASSERT_EQ(mix->status, 201) << mix->body;
    const std::string mid = json::parse(mix->body).at("id");
    for (const std::string& path : {"/v1/textons/" + id, "/v1/mixes/" + mid + "/tiles/0/0/0.png"})
        for (int i = 0; i < 3; ++i) {
            auto r = get(b, path);
            ASSERT_TRUE(r);
            EXPECT_EQ(r->status, 503) << path << " " << i << ": " << r->body;
            EXPECT_EQ(json::parse(r->body)["error"]["code"], "store_unavailable") << r->body;
            EXPECT_NE(r->body.find("disk is full"), std::string::npos) << r->body;
            EXPECT_EQ(r->body.find(dir_b), std::string::npos) << r->body;
            EXPECT_EQ(r->get_header_value("Retry-After"), "1");
        }
    EXPECT_EQ(status_of(a, "/v1/mixes/" + mid + "/tiles/0/0/0.png"), 200);
    // Nothing half-copied is left for a later read to take whole.
    for (const auto& e : fs::directory_iterator(fs::path(dir_b) / "mixes"))
        EXPECT_EQ(e.path().filename().string().find(mid), std::string::npos) << e.path();
    const std::string before = redis.cli({"ZCARD", "textond:v1:ids"});
    auto cb = b.client();
    auto up = cb.Post("/v1/textons?size=16&iterations=5",
                      read_file(exemplar_path("etr_pave02.png")), "image/png");
    ASSERT_TRUE(up);
    EXPECT_EQ(up->status, 507) << up->body;
    EXPECT_EQ(redis.cli({"ZCARD", "textond:v1:ids"}), before);
    EXPECT_EQ(json::parse(get(a, "/v1/textons")->body).at("total"), 2);
}

// An id analysed again (deleted, then uploaded anew) is a new job: its end is published too, and
// the older job's end, still remembered, never overwrites it. The board had remembered ids, so a
// second end was never published and the other replicas answered "running" until it expired.
TEST(SharedStore, AnIdAnalysedAgainPublishesItsOwnEnd) {
    RedisProcess redis(fresh_dir("job-board-redis"));
    auto address = store::parse_redis_url(redis.url());
    ASSERT_TRUE(address);
    store::RedisStore shared(address.value(), std::chrono::milliseconds(2000));
    app::AnalysisPool pool(1, 4);
    auto name = [](const app::AnalysisJob& job) {
        return std::to_string(reinterpret_cast<std::uintptr_t>(&job));
    };
    app::JobBoard board(pool, &shared, [&](const app::AnalysisJob& job) {
        return json{{"id", job.id()}, {"state", app::to_string(job.state())}, {"job", name(job)}};
    });
    const std::string id(64, 'a');
    auto published = [&] {
        auto got = shared.get_job(id);
        EXPECT_TRUE(got && got.value());
        return got && got.value() ? json::parse(*got.value()) : json{};
    };
    auto fails = [](const core::ProgressFn&) -> Result<app::AnalysisOutcome> {
        return make_error(ErrorCode::unprocessable, "no texture here");
    };
    auto first = pool.submit(id, fails).job;
    ASSERT_TRUE(first);
    first->wait();
    board.publish(first);
    EXPECT_EQ(published()["job"], name(*first));

    std::promise<void> release;
    auto go = release.get_future().share();
    auto second = pool.submit(id,
                              [go, fails](const core::ProgressFn& p) {
                                  go.wait();
                                  return fails(p);
                              })
                      .job;
    ASSERT_TRUE(second);
    ASSERT_NE(second, first);
    board.publish(second);
    // Queued or already running (the worker may have taken it), and the second job's.
    EXPECT_EQ(published()["job"], name(*second));
    EXPECT_NE(published()["state"], "failed");
    release.set_value();
    second->wait();
    board.publish(second);
    EXPECT_EQ(published()["job"], name(*second));
    EXPECT_EQ(published()["state"], "failed");
    // The board's sweep (each second) republishes the pool's jobs: the second's answer stays.
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));
    EXPECT_EQ(published()["job"], name(*second));
}

// A splat or mix deleted through another replica: the replica that made it erases its files at
// its next sweep, unasked (they had stayed on its disk for good, and a flushed Redis got them
// back as "missing": the deleted objects were served again everywhere). A replica also removes,
// when it starts, the temporaries of writes a crash interrupted there.
TEST(SharedStore, ASplatOrMixDeletedElsewhereLeavesNoFilesAndNeverComesBack) {
    RedisProcess redis(fresh_dir("shared-h-redis"));
    const std::string dir_a = fresh_dir("shared-h-1");
    for (const char* sub : {"mixes", "splats"}) {
        fs::create_directories(fs::path(dir_a) / sub);
        std::ofstream(fs::path(dir_a) / sub / ("." + std::string(64, 'd') + ".exr.tmp-AbCdEf"))
            << "half a file";
    }
    ServerProcess a(dir_a, replica_args(redis));
    ServerProcess b(fresh_dir("shared-h-2"), replica_args(redis));
    for (const char* sub : {"mixes", "splats"})
        EXPECT_TRUE(fs::is_empty(fs::path(dir_a) / sub)) << sub << ": the unfinished write stays";
    auto ca = a.client();
    const std::string u = upload(ca, "etr_sand01.png", "?size=16&iterations=5");
    const std::string v = upload(ca, "etr_pebbles04.png", "?size=16&iterations=5");
    const auto [mid, sid] = mix_and_splat(ca, u, v);
    ASSERT_FALSE(mid.empty());
    auto cb = b.client();
    for (const std::string& path : {"/v1/mixes/" + mid, "/v1/splats/" + sid}) {
        auto del = cb.Delete(path.c_str());
        ASSERT_TRUE(del);
        EXPECT_EQ(del->status, 204) << path << ": " << del->body;
    }
    EXPECT_TRUE(eventually(
        [&] {
            return fs::is_empty(fs::path(dir_a) / "mixes") &&
                   fs::is_empty(fs::path(dir_a) / "splats");
        },
        5.0))
        << "a kept the files of what b deleted";
    redis.cli({"FLUSHALL"});
    std::this_thread::sleep_for(std::chrono::milliseconds(2500)); // two sweeps
    EXPECT_EQ(redis.cli({"EXISTS", "textond:v1:mix:" + mid}), "0\n");
    EXPECT_EQ(redis.cli({"EXISTS", "textond:v1:splat:" + sid}), "0\n");
    for (const ServerProcess* s : {&a, &b}) {
        EXPECT_EQ(status_of(*s, "/v1/mixes/" + mid), 404);
        EXPECT_EQ(status_of(*s, "/v1/splats/" + sid), 404);
    }
}

// The sweep erases what a tombstone names, but never while the id is being created here again:
// those files are the new object's.
TEST(SharedObjects, TheSweepErasesADeletedCopyButNotACreationInFlight) {
    RedisProcess redis(fresh_dir("shared-i-redis"));
    store::RedisStore shared(store::parse_redis_url(redis.url()).value(),
                             std::chrono::milliseconds(2000));
    const std::string dir = fresh_dir("shared-i-dir");
    store::SharedObjects objects(&shared, "mix", dir, {{".json", 1 << 20}},
                                 std::chrono::milliseconds(100));
    const std::string id(64, 'f');
    const std::string file = dir + "/" + id + ".json";
    std::ofstream(file) << "{}";
    ASSERT_TRUE(objects.publish(id).value());
    ASSERT_TRUE(shared.remove_object("mix", id).value()); // deleted by another replica
    {
        const store::InFlightIds::Mark creating(objects.creations(), id);
        std::this_thread::sleep_for(std::chrono::milliseconds(500)); // five sweeps
        EXPECT_TRUE(fs::exists(file)) << "a creation's files were erased";
    }
    EXPECT_TRUE(eventually([&] { return !fs::exists(file); }, 3.0)) << "the deleted copy stays";
}

} // namespace
} // namespace textond::test
