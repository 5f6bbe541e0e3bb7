#pragma once
// The shared texton store on Redis (`serve --store redis://...`): every replica writes the
// textons it analyses here and reads the ones it lacks from here, keeping a local copy (the
// data directory becomes a read-through cache, server/store/texton_store.h).
//
// Layout, under the prefix "textond:v1:":
//   texton:<id>   hash {file: the texton file bytes (api/TEXTON_FORMAT.md), sha256: of file,
//                 meta: the metadata JSON, exemplar: the exemplar PNG, exemplar_sha256}
//   ids           sorted set of ids (score 0, ordered by id: cursor pages with ZRANGEBYLEX)
//   deleted:<id>  a tombstone, so replicas drop their local copies of deleted textons
//   job:<id>      an analysis's status answer while it runs (put_job; it expires)
// A texton is written once, by one Lua script (atomic: readers see all of it or nothing), and
// only when absent: of two replicas that analyse the same exemplar at once, one stores it and
// the other adopts that one. The file's sha256 is checked on every read, so a value damaged in
// Redis is refused, never cached or served. Not for Redis Cluster (the keys span slots).
#include "core/result.h"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

struct redisContext;

namespace textond::store {

struct RedisAddress {
    std::string host;
    int port = 6379;
    int db = 0;
    std::string user;     // Redis 6 ACL user; empty = AUTH with the password alone
    std::string password; // empty = no AUTH
};

// redis://[[user]:password@]host[:port][/db]
Result<RedisAddress> parse_redis_url(const std::string& url);

class RedisStore {
public:
    // Does not connect: a replica starts (and serves its local copies) while Redis is down.
    RedisStore(RedisAddress address, std::chrono::milliseconds timeout);
    ~RedisStore();
    RedisStore(const RedisStore&) = delete;
    RedisStore& operator=(const RedisStore&) = delete;

    // "redis://host:port/db" (no password), for logs and /readyz.
    std::string describe() const;
    // Why the store refused its last write, within the last minute (Redis full: OOM with
    // noeviction; READONLY...): uploads answer 503 before their analysis and /readyz says
    // degraded. Empty when writes go through.
    std::string write_refusal() const;
    // The store holds a texton's values, but not this verified copy's (a damaged or replaced
    // entry, told by the file's length or checksum field): they are rewritten from it.
    Result<bool> repair_if_differs(const std::string& id, const std::string& file,
                                   const std::string& meta_json, const std::string& exemplar_png);

    // True when this call stored it, false when it was there already. Clears a tombstone; with
    // `write_back` (a copy held here, which the store lost) it stores nothing over a tombstone.
    Result<bool> put(const std::string& id, const std::string& file, const std::string& meta_json,
                     const std::string& exemplar_png, bool write_back = false);
    struct Texton {
        std::string file;
        std::string exemplar_png; // empty when stored without one
        std::string meta_json;    // as put (provenance included); not checksummed, advisory
        std::string signature;    // sizes and checksums: refuse_texton's key when it fails later
    };
    // A texton whose values passed their checksums but failed the reader's checks: not read
    // again while they stay the same.
    void refuse_texton(const std::string& id, const std::string& signature);
    // Both checked against their sha256; nullopt when absent.
    Result<std::optional<Texton>> get(const std::string& id);
    // What a stored texton's values can hold: its file (256 x 256 x 8 float32 coefficients and
    // metadata, 2.1 MB at most, with room), its exemplar as PNG (--max-pixels of 16-bit RGB,
    // compressed at worst not at all) and its metadata. A larger value is never read.
    static constexpr long long kMaxFileBytes = 8LL << 20;
    static constexpr long long kMaxExemplarBytes = 112LL << 20;
    static constexpr long long kMaxMetaBytes = 1LL << 20;
    // What the exemplar PNG of a texton whose exemplar is width x height can hold (8-bit, at most
    // four channels, stored uncompressed at worst); 0 for no exemplar size. The metadata's size
    // bounds the exemplar that is read: 100 MB under a small texton is refused unread.
    static long long exemplar_cap(long long width, long long height);
    // Present, deleted (tombstone) or neither (unknown: a copy held only locally).
    enum class Presence { present, deleted, unknown };
    Result<Presence> presence(const std::string& id);
    // False when it was not there.
    Result<bool> remove(const std::string& id);
    // Metadata JSON of the ids after `after` (exclusive), ascending, at most `limit`.
    // (id, metadata JSON) of the ids after `after`, as stored: the id is the key's, the JSON
    // whatever the value holds (the caller checks that they agree).
    // A page reads at most kListPageBytes of metadata, each at most kMaxListedMetaBytes (a
    // texton's is a few kB): `more` is set when the page ended early for it.
    Result<std::vector<std::pair<std::string, std::string>>>
    list_meta(const std::string& after, int limit, bool* more = nullptr);
    static constexpr long long kMaxListedMetaBytes = 64LL << 10;
    static constexpr std::size_t kListPageBytes = std::size_t{8} << 20;
    Result<std::uint64_t> count();
    // Up: Redis answers PING, and no write was refused in the last minute (a full or read-only
    // Redis answers PING and still loses uploads).
    Result<bool> up();

    // Splats and mixes: an object of `kind` ("splat", "mix") is the files of
    // its directory by suffix, under "<kind>:<id>" as {<suffix>: bytes, <suffix>.sha256: hex},
    // written once (true when this call stored it) and tombstoned by "deleted-<kind>:<id>" when
    // removed, as textons are.
    using Files = std::map<std::string, std::string>; // suffix -> bytes
    Result<bool> put_object(const std::string& kind, const std::string& id, const Files& files,
                            bool write_back = false);
    // Each file's size checked against `caps` (suffix -> most bytes; a stored suffix not named is
    // refused) before anything is read, then its checksum; nullopt when absent.
    // `signature` receives what identifies the values read (sizes and checksums): a caller that
    // finds them damaged gives it back to refuse_object, and they are not read again.
    Result<std::optional<Files>> get_object(const std::string& kind, const std::string& id,
                                            const std::map<std::string, long long>& caps,
                                            std::string* signature = nullptr);
    void refuse_object(const std::string& kind, const std::string& id,
                       const std::string& signature);
    Result<Presence> object_presence(const std::string& kind, const std::string& id);
    Result<bool> remove_object(const std::string& kind, const std::string& id);
    // An analysis in flight on some replica, by texton id: `job:<id>`, a small JSON that expires
    // after `ttl` (its replica publishes it again while the job lives; server/app/job_board.h).
    // A value over kMaxJobBytes is never read (nullopt, as absent).
    static constexpr std::size_t kMaxJobBytes = 4096;
    Result<bool> put_job(const std::string& id, const std::string& json, std::chrono::seconds ttl);
    Result<std::optional<std::string>> get_job(const std::string& id);
    // Room left under Redis's maxmemory (INFO memory): an error when it is full or evicts (a
    // policy other than noeviction loses textons).
    std::optional<std::string> memory_warning();
    // What /readyz and textond_shared_store_up both say: `up` as up() says, and the problem (up's
    // error, else memory_warning's) that makes a replica degraded.
    struct Health {
        bool up = false;
        std::optional<std::string> problem;
    };
    Health health();

private:
    struct Reply;
    class Connection;
    // Runs one command (argv) on a pooled connection; on a broken connection, retries once on a
    // fresh one (every command here is idempotent), then reports the store unavailable and
    // fails fast for a second so a dead Redis does not slow every request.
    // `large_bytes`: what the replies may hold, which lengthens the timeout.
    Result<std::shared_ptr<Reply>> command(const std::vector<std::string>& argv,
                                           std::size_t large_bytes = 0);
    Result<std::vector<std::shared_ptr<Reply>>>
    pipeline(const std::vector<std::vector<std::string>>& commands, std::size_t large_bytes = 0);
    // Values read from the store at once, all requests together, are held to kFetchBudget
    // (eight ids of 100 MB each once took a replica +874 MB and the store down for a second).
    class FetchLease {
    public:
        FetchLease(RedisStore* store, std::size_t bytes) : m_store(store), m_bytes(bytes) {}
        ~FetchLease();
        FetchLease(const FetchLease&) = delete;
        FetchLease& operator=(const FetchLease&) = delete;

    private:
        RedisStore* m_store;
        std::size_t m_bytes;
    };
    Result<std::unique_ptr<FetchLease>> reserve_fetch(std::size_t bytes);
    static constexpr std::size_t kFetchBudget = std::size_t{192} << 20;
    void forget_refused(const std::string& memo);
    Result<std::unique_ptr<Connection>> acquire();
    // Runs a write script that answers 0 or 1, remembering a refusal (full, read-only).
    Result<bool> write_script(const std::vector<std::string>& argv);
    void release(std::unique_ptr<Connection> c);
    Error unavailable(const std::string& why);
    void mark(bool up, const std::string& error = {});
    // A texton refused as damaged is remembered with its values' sizes ("file:exemplar:meta"),
    // so it is not read again until they change (at most kMaxRemembered ids).
    bool refused_before(const std::string& id, const std::string& sizes) const;
    void remember_refused(const std::string& id, const std::string& sizes);
    static constexpr std::size_t kMaxRemembered = 4096;

    const RedisAddress m_address;
    const std::chrono::milliseconds m_timeout;
    mutable std::mutex m_mutex;
    std::vector<std::unique_ptr<Connection>> m_idle;
    std::chrono::steady_clock::time_point m_retry_at{};
    std::optional<bool> m_up; // as the last command found it; unset before the first
    std::string m_last_error = "not connected yet";
    std::string m_write_refusal;
    // id -> (sizes and checksums, when) of a refused value
    std::map<std::string, std::pair<std::string, std::chrono::steady_clock::time_point>> m_refused;
    static constexpr auto kRefusalMemory = std::chrono::minutes(1);
    struct TextonProbe {
        bool exists = false;
        long long len[3] = {0, 0, 0}; // file, exemplar, meta
        std::optional<std::string> file_sha, png_sha;
        std::string signature;
    };
    Result<TextonProbe> probe_texton(const std::string& id);
    // After a read that found a value gone (`why` empty) or failing its checksum (`why`):
    // absent, changed while read (unavailable), or refused as damaged.
    Result<std::optional<Texton>> reprobe(const std::string& id, const TextonProbe& p,
                                          const std::string& why);
    struct ObjectProbe {
        std::vector<std::string> present, sums; // the files stored, and their checksums
        std::size_t total = 0;
        std::string signature;
    };
    Result<ObjectProbe> probe_object(const std::string& key, const std::string& what,
                                     const std::map<std::string, long long>& caps);
    Result<std::unique_ptr<std::optional<std::string>>>
    read_exemplar(const std::string& key, const TextonProbe& p, long long cap);
    std::mutex m_fetch_mutex;
    std::condition_variable m_fetch_cv;
    std::size_t m_fetching_bytes = 0;
    std::chrono::steady_clock::time_point m_write_refused_at{};
};

} // namespace textond::store
