#include "server/store/redis_store.h"

#include "api/safe_text.h"
#include "server/io/sha256.h"

#include <hiredis/hiredis.h>
#include <spdlog/spdlog.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <sys/time.h>

namespace textond::store {

namespace {

constexpr const char* kPrefix = "textond:v1:";
constexpr std::size_t kMaxIdle = 16;
constexpr auto kRetryAfterFailure = std::chrono::seconds(1);

std::string texton_key(const std::string& id) {
    return std::string(kPrefix) + "texton:" + id;
}
std::string tombstone_key(const std::string& id) {
    return std::string(kPrefix) + "deleted:" + id;
}
std::string job_key(const std::string& id) {
    return std::string(kPrefix) + "job:" + id;
}
std::string ids_key() {
    return std::string(kPrefix) + "ids";
}

// Write-once: a texton is stored only when absent, all fields at once, with its id indexed.
// An index of another type is refused before anything is written (a texton stored but never
// indexed would answer 200 to its next upload and never be listed).
constexpr const char* kPutScript = R"lua(
local index = redis.call('TYPE', KEYS[2])['ok']
if index ~= 'zset' and index ~= 'none' then
  return redis.error_reply('WRONGTYPE the id index ' .. KEYS[2] .. ' is a ' .. index)
end
if redis.call('EXISTS', KEYS[1]) == 1 then return 0 end
redis.call('HSET', KEYS[1], 'file', ARGV[1], 'sha256', ARGV[2], 'meta', ARGV[3],
           'exemplar', ARGV[4], 'exemplar_sha256', ARGV[5])
redis.call('ZADD', KEYS[2], 0, ARGV[6])
redis.call('DEL', KEYS[3])
return 1
)lua";

// A repair rewrites a texton's values only while it is there and not deleted: a delete that
// lands between the caller's look and this write must win (a plain HSET had brought a deleted
// texton back, unlisted and beside its tombstone, and every replica served it).
constexpr const char* kRepairScript = R"lua(
if redis.call('EXISTS', KEYS[1]) == 0 or redis.call('EXISTS', KEYS[2]) == 1 then return 0 end
redis.call('HSET', KEYS[1], 'file', ARGV[1], 'sha256', ARGV[2], 'meta', ARGV[3],
           'exemplar', ARGV[4], 'exemplar_sha256', ARGV[5])
return 1
)lua";

// A replica's copy written back to a store that lost it (a flushed Redis): as kPutScript, but
// never over a tombstone, which a delete may have left since the replica looked; an upload
// (kPutScript) clears one, a write-back must not undo the delete.
constexpr const char* kWriteBackScript = R"lua(
local index = redis.call('TYPE', KEYS[2])['ok']
if index ~= 'zset' and index ~= 'none' then
  return redis.error_reply('WRONGTYPE the id index ' .. KEYS[2] .. ' is a ' .. index)
end
if redis.call('EXISTS', KEYS[1]) == 1 or redis.call('EXISTS', KEYS[3]) == 1 then return 0 end
redis.call('HSET', KEYS[1], 'file', ARGV[1], 'sha256', ARGV[2], 'meta', ARGV[3],
           'exemplar', ARGV[4], 'exemplar_sha256', ARGV[5])
redis.call('ZADD', KEYS[2], 0, ARGV[6])
return 1
)lua";

// Splats and mixes written back, on the same rule.
constexpr const char* kWriteBackObjectScript = R"lua(
if redis.call('EXISTS', KEYS[1]) == 1 or redis.call('EXISTS', KEYS[2]) == 1 then return 0 end
redis.call('HSET', KEYS[1], unpack(ARGV))
return 1
)lua";

// Splats and mixes: the same write-once rule, with any number of fields.
constexpr const char* kPutObjectScript = R"lua(
if redis.call('EXISTS', KEYS[1]) == 1 then return 0 end
redis.call('HSET', KEYS[1], unpack(ARGV))
redis.call('DEL', KEYS[2])
return 1
)lua";

constexpr const char* kRemoveObjectScript = R"lua(
local n = redis.call('DEL', KEYS[1])
redis.call('SET', KEYS[2], '1')
return n
)lua";

std::string object_key(const std::string& kind, const std::string& id) {
    return std::string(kPrefix) + kind + ":" + id;
}
std::string object_tombstone_key(const std::string& kind, const std::string& id) {
    return std::string(kPrefix) + "deleted-" + kind + ":" + id;
}

// A page of ids, leaving out any member that is no id (64 hex digits): a 60 MB member once cost
// each list its size in the replica. Redis reads it; the replica never receives it.
constexpr const char* kListIdsScript = R"lua(
local ids = redis.call('ZRANGEBYLEX', KEYS[1], ARGV[1], '+', 'LIMIT', 0, tonumber(ARGV[2]))
local out = {}
for _, id in ipairs(ids) do
  if #id == 64 and not string.find(id, '[^0-9a-f]') then out[#out + 1] = id end
end
return out
)lua";

constexpr const char* kRemoveScript = R"lua(
local n = redis.call('DEL', KEYS[1])
redis.call('ZREM', KEYS[2], ARGV[1])
redis.call('SET', KEYS[3], '1')
return n
)lua";

bool parse_int(std::string_view s, int lo, int hi, int& out) {
    int v = 0;
    auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size() || v < lo || v > hi) return false;
    out = v;
    return true;
}

timeval to_timeval(std::chrono::milliseconds ms) {
    timeval tv{};
    tv.tv_sec = static_cast<time_t>(ms.count() / 1000);
    tv.tv_usec = static_cast<suseconds_t>((ms.count() % 1000) * 1000);
    return tv;
}

} // namespace

Result<RedisAddress> parse_redis_url(const std::string& url) {
    auto bad = [&](const std::string& why) {
        return make_error(ErrorCode::invalid_argument,
                          "--store: " + why +
                              " (expected redis://[[user]:password@]host[:port][/db])");
    };
    const std::string scheme = "redis://";
    if (url.rfind(scheme, 0) != 0) return bad("not a redis:// URL");
    std::string rest = url.substr(scheme.size());
    RedisAddress a;
    if (const auto at = rest.rfind('@'); at != std::string::npos) {
        const std::string auth = rest.substr(0, at);
        rest = rest.substr(at + 1);
        const auto colon = auth.find(':');
        if (colon == std::string::npos) return bad("credentials must be [user]:password");
        a.user = auth.substr(0, colon);
        a.password = auth.substr(colon + 1);
    }
    if (const auto slash = rest.find('/'); slash != std::string::npos) {
        const std::string db = rest.substr(slash + 1);
        rest = rest.substr(0, slash);
        if (!db.empty() && !parse_int(db, 0, 1 << 20, a.db)) return bad("bad database number");
    }
    if (!rest.empty() && rest.front() == '[') { // [::1]:6379
        const auto close = rest.find(']');
        if (close == std::string::npos) return bad("unclosed [");
        a.host = rest.substr(1, close - 1);
        rest = rest.substr(close + 1);
        if (!rest.empty() && (rest.front() != ':' || !parse_int(rest.substr(1), 1, 65535, a.port)))
            return bad("bad port");
    } else if (const auto colon = rest.find(':'); colon != std::string::npos) {
        a.host = rest.substr(0, colon);
        if (!parse_int(rest.substr(colon + 1), 1, 65535, a.port)) return bad("bad port");
    } else {
        a.host = rest;
    }
    if (a.host.empty()) return bad("no host");
    return a;
}

struct RedisStore::Reply {
    redisReply* r;
    explicit Reply(redisReply* p) : r(p) {}
    ~Reply() { freeReplyObject(r); }
    Reply(const Reply&) = delete;
    Reply& operator=(const Reply&) = delete;
    bool nil() const { return r->type == REDIS_REPLY_NIL; }
    long long integer() const { return r->type == REDIS_REPLY_INTEGER ? r->integer : -1; }
    static std::optional<std::string> string(const redisReply* e) {
        if (e->type != REDIS_REPLY_STRING) return std::nullopt;
        return std::string(e->str, e->len);
    }
};

class RedisStore::Connection {
public:
    static Result<std::unique_ptr<Connection>> open(const RedisAddress& a,
                                                    std::chrono::milliseconds timeout) {
        redisContext* c = redisConnectWithTimeout(a.host.c_str(), a.port, to_timeval(timeout));
        if (!c) return make_error(ErrorCode::unavailable, "cannot allocate a Redis connection");
        std::unique_ptr<Connection> conn(new Connection(c));
        if (c->err) return make_error(ErrorCode::unavailable, c->errstr);
        redisSetTimeout(c, to_timeval(timeout));
        redisEnableKeepAlive(c);
        std::vector<std::vector<std::string>> setup;
        if (!a.password.empty())
            setup.push_back(a.user.empty() ? std::vector<std::string>{"AUTH", a.password}
                                           : std::vector<std::string>{"AUTH", a.user, a.password});
        if (a.db != 0) setup.push_back({"SELECT", std::to_string(a.db)});
        for (const auto& argv : setup) {
            auto r = conn->run({argv});
            if (!r) return r.error();
            if (r.value()[0]->r->type == REDIS_REPLY_ERROR)
                return make_error(ErrorCode::unavailable,
                                  argv[0] + " failed: " + std::string(r.value()[0]->r->str));
        }
        return conn;
    }
    ~Connection() { redisFree(m_c); }

    // Sends every command, then reads every reply (one round trip). An error here means the
    // connection is broken and must be dropped.
    // `timeout`: this round trip's, when longer than the connection's (a large value's read).
    Result<std::vector<std::shared_ptr<Reply>>>
    run(const std::vector<std::vector<std::string>>& commands,
        std::chrono::milliseconds timeout = std::chrono::milliseconds(0),
        std::chrono::milliseconds usual = std::chrono::milliseconds(0)) {
        if (timeout > usual) redisSetTimeout(m_c, to_timeval(timeout));
        auto out = run_all(commands);
        if (timeout > usual && out) redisSetTimeout(m_c, to_timeval(usual));
        return out;
    }

private:
    Result<std::vector<std::shared_ptr<Reply>>>
    run_all(const std::vector<std::vector<std::string>>& commands) {
        for (const auto& argv : commands) {
            std::vector<const char*> ptrs;
            std::vector<std::size_t> lens;
            for (const auto& s : argv) {
                ptrs.push_back(s.data());
                lens.push_back(s.size());
            }
            if (redisAppendCommandArgv(m_c, static_cast<int>(argv.size()), ptrs.data(),
                                       lens.data()) != REDIS_OK)
                return make_error(ErrorCode::unavailable, m_c->errstr);
        }
        std::vector<std::shared_ptr<Reply>> out;
        for (std::size_t i = 0; i < commands.size(); ++i) {
            void* r = nullptr;
            if (redisGetReply(m_c, &r) != REDIS_OK || !r)
                return make_error(ErrorCode::unavailable, m_c->err ? m_c->errstr : "no reply");
            out.push_back(std::make_shared<Reply>(static_cast<redisReply*>(r)));
        }
        return out;
    }

    explicit Connection(redisContext* c) : m_c(c) {}
    redisContext* m_c;
};

RedisStore::RedisStore(RedisAddress address, std::chrono::milliseconds timeout)
    : m_address(std::move(address)), m_timeout(timeout) {}

RedisStore::~RedisStore() = default;

std::string RedisStore::describe() const {
    const bool v6 = m_address.host.find(':') != std::string::npos;
    return "redis://" + (v6 ? "[" + m_address.host + "]" : m_address.host) + ":" +
           std::to_string(m_address.port) + "/" + std::to_string(m_address.db);
}

void RedisStore::mark(bool up, const std::string& error) {
    std::lock_guard lock(m_mutex);
    if (m_up != up) {
        if (up)
            spdlog::info("shared store {} is up", describe());
        else
            spdlog::error("shared store {} is unavailable: {}", describe(), error);
    }
    m_up = up;
    if (!up) {
        m_last_error = error;
        m_retry_at = std::chrono::steady_clock::now() + kRetryAfterFailure;
        m_idle.clear(); // the other pooled connections went down with it
    }
}

Error RedisStore::unavailable(const std::string& why) {
    return make_error(ErrorCode::unavailable,
                      "the shared texton store (" + describe() + ") is unavailable: " + why);
}

Result<std::unique_ptr<RedisStore::Connection>> RedisStore::acquire() {
    {
        std::lock_guard lock(m_mutex);
        if (!m_idle.empty()) {
            auto c = std::move(m_idle.back());
            m_idle.pop_back();
            return c;
        }
        if (std::chrono::steady_clock::now() < m_retry_at) return unavailable(m_last_error);
    }
    auto c = Connection::open(m_address, m_timeout);
    if (!c) {
        mark(false, c.error().message);
        return unavailable(c.error().message);
    }
    return c;
}

void RedisStore::release(std::unique_ptr<Connection> c) {
    std::lock_guard lock(m_mutex);
    if (m_idle.size() < kMaxIdle) m_idle.push_back(std::move(c));
}

Result<std::vector<std::shared_ptr<RedisStore::Reply>>>
RedisStore::pipeline(const std::vector<std::vector<std::string>>& commands,
                     std::size_t large_bytes) {
    // A large value's read gets the time its size takes (10 MB/s at worst) on top of the usual
    // timeout: a slow 100 MB read once timed out and called the whole store down.
    const std::chrono::milliseconds timeout =
        m_timeout + std::chrono::milliseconds(large_bytes / (10 * 1000));
    for (int attempt = 0;; ++attempt) {
        auto conn = acquire();
        if (!conn) return conn.error();
        auto replies = conn.value()->run(commands, timeout, m_timeout);
        if (!replies) {
            // A pooled connection may have died with an earlier Redis (restart, timeout): one
            // retry on a fresh connection before calling the store down.
            if (attempt == 0) {
                std::lock_guard lock(m_mutex);
                m_idle.clear();
                continue;
            }
            mark(false, replies.error().message);
            return unavailable(replies.error().message);
        }
        release(std::move(conn.value()));
        mark(true);
        // OOM, READONLY, NOAUTH...: the store cannot serve this. WRONGTYPE is one key's (a value
        // of another type where ours should be): left in its reply for the caller, which refuses
        // that key alone (one such key made every list 503 store_unavailable).
        for (const auto& r : replies.value())
            if (r->r->type == REDIS_REPLY_ERROR &&
                std::string_view(r->r->str, r->r->len).rfind("WRONGTYPE", 0) != 0)
                return unavailable(std::string(r->r->str, r->r->len));
        return replies;
    }
}

Result<std::shared_ptr<RedisStore::Reply>> RedisStore::command(const std::vector<std::string>& argv,
                                                               std::size_t large_bytes) {
    auto r = pipeline({argv}, large_bytes);
    if (!r) return r.error();
    return r.value()[0];
}

std::string RedisStore::write_refusal() const {
    std::lock_guard lock(m_mutex);
    if (m_write_refusal.empty() ||
        std::chrono::steady_clock::now() > m_write_refused_at + std::chrono::minutes(1))
        return "";
    return m_write_refusal;
}

Result<bool> RedisStore::put(const std::string& id, const std::string& file,
                             const std::string& meta_json, const std::string& exemplar_png,
                             bool write_back) {
    forget_refused(id);
    return write_script({"EVAL", write_back ? kWriteBackScript : kPutScript, "3", texton_key(id),
                         ids_key(), tombstone_key(id), file, io::sha256_hex(file), meta_json,
                         exemplar_png, io::sha256_hex(exemplar_png), id});
}

Result<bool> RedisStore::write_script(const std::vector<std::string>& argv) {
    auto r = command(argv);
    const auto refused = [&](const std::string& why) {
        std::lock_guard lock(m_mutex);
        m_write_refusal = why;
        m_write_refused_at = std::chrono::steady_clock::now();
    };
    if (!r) {
        if (m_up.value_or(false)) refused(r.error().message); // up, yet refusing (OOM, READONLY)
        return r.error();
    }
    // A key of another type where ours should be: this write's key, not the store (500).
    if (r.value()->r->type == REDIS_REPLY_ERROR)
        return make_error(ErrorCode::io, "the shared store refused the write: " +
                                             std::string(r.value()->r->str, r.value()->r->len));
    // The script answers 0 or 1; anything else is no Redis we know (one answering +OK to all).
    if (r.value()->r->type != REDIS_REPLY_INTEGER) {
        refused("the store answered the write with something else than 0 or 1");
        return unavailable("the shared store answered a write strangely: not a Redis?");
    }
    {
        std::lock_guard lock(m_mutex);
        m_write_refusal.clear();
    }
    return r.value()->integer() == 1;
}

Result<bool> RedisStore::repair_if_differs(const std::string& id, const std::string& file,
                                           const std::string& meta_json,
                                           const std::string& exemplar_png) {
    const std::string sha = io::sha256_hex(file);
    auto r = pipeline({{"HSTRLEN", texton_key(id), "file"}, {"HSTRLEN", texton_key(id), "sha256"}});
    if (!r) return r.error();
    if (r.value()[0]->integer() == static_cast<long long>(file.size()) &&
        r.value()[1]->integer() == static_cast<long long>(sha.size())) {
        auto stored = command({"HGET", texton_key(id), "sha256"}); // 64 bytes, checked above
        if (!stored) return stored.error();
        if (Reply::string(stored.value()->r) == sha) return false;
    }
    return write_script({"EVAL", kRepairScript, "2", texton_key(id), tombstone_key(id), file, sha,
                         meta_json, exemplar_png, io::sha256_hex(exemplar_png)});
}

long long RedisStore::exemplar_cap(long long width, long long height) {
    if (width <= 0 || height <= 0 || width > (1 << 20) || height > (1 << 20)) return 0;
    // An 8-bit PNG of at most four channels: a filter byte a row, zlib's stored blocks at worst
    // (5 bytes a 64 KiB), libpng's 8 KiB IDAT chunks (12 bytes each), headers.
    const long long raw = (width * 4 + 1) * height;
    return std::min(kMaxExemplarBytes, raw + raw / 100 + (64LL << 10));
}

bool RedisStore::refused_before(const std::string& id, const std::string& sizes) const {
    std::lock_guard lock(m_mutex);
    const auto it = m_refused.find(id);
    // A minute at most: a value restored in place with the same sizes and checksums (a
    // same-length corruption fixed from a backup) is read again then.
    return it != m_refused.end() && it->second.first == sizes &&
           std::chrono::steady_clock::now() < it->second.second + kRefusalMemory;
}

void RedisStore::remember_refused(const std::string& id, const std::string& sizes) {
    std::lock_guard lock(m_mutex);
    if (m_refused.size() >= kMaxRemembered && !m_refused.count(id))
        m_refused.erase(m_refused.begin()); // any: a forgotten one costs one read more
    m_refused[id] = {sizes, std::chrono::steady_clock::now()};
}

RedisStore::FetchLease::~FetchLease() {
    if (!m_store) return;
    {
        std::lock_guard lock(m_store->m_fetch_mutex);
        m_store->m_fetching_bytes -= m_bytes;
    }
    m_store->m_fetch_cv.notify_all();
}

Result<std::unique_ptr<RedisStore::FetchLease>> RedisStore::reserve_fetch(std::size_t bytes) {
    bytes = std::min(bytes, kFetchBudget); // one alone always fits
    std::unique_lock lock(m_fetch_mutex);
    if (!m_fetch_cv.wait_for(lock, std::chrono::seconds(10),
                             [&] { return m_fetching_bytes + bytes <= kFetchBudget; }))
        return make_error(ErrorCode::unavailable,
                          "the shared store's reads are busy (large values in flight); retry");
    m_fetching_bytes += bytes;
    return std::make_unique<FetchLease>(this, bytes);
}

// A texton's fields sized before any value is read: its values' lengths, its checksums (64
// bytes each, read once sized) and what identifies them together (the refusal memory's key).
// One script, so the sizes and checksums are of one version of the texton: as separate
// commands, a delete and a new upload between them gave sizes without checksums, and a sound
// texton was refused as damaged.
constexpr const char* kProbeScript = R"lua(
local k = KEYS[1]
if redis.call('EXISTS', k) == 0 then return {0} end
if redis.call('TYPE', k)['ok'] ~= 'hash' then return {-1} end
local out = {1, redis.call('HSTRLEN', k, 'file'), redis.call('HSTRLEN', k, 'exemplar'),
             redis.call('HSTRLEN', k, 'meta'), redis.call('HSTRLEN', k, 'sha256'),
             redis.call('HSTRLEN', k, 'exemplar_sha256'), redis.call('HLEN', k), false, false}
if out[5] <= 64 and out[6] <= 64 and out[7] <= 5 then
  out[8] = redis.call('HGET', k, 'sha256')
  out[9] = redis.call('HGET', k, 'exemplar_sha256')
end
return out
)lua";

namespace {
// The reply of a probe script (kProbeScript, kProbeObjectScript): {0} when the key is absent
// (nullptr here), {-1} when it holds another type, else `elements` values after a 1.
Result<const redisReply*> probed(const redisReply* z, std::size_t elements,
                                 const std::string& what) {
    if (z->type != REDIS_REPLY_ARRAY || z->elements < 1 ||
        z->element[0]->type != REDIS_REPLY_INTEGER ||
        (z->element[0]->integer > 0 && z->elements != elements))
        return make_error(ErrorCode::io, "unexpected Redis reply to the probe of " + what);
    if (z->element[0]->integer < 0)
        return make_error(ErrorCode::io, what + " is a value of another type; it is not read");
    return z->element[0]->integer == 0 ? nullptr : z;
}
} // namespace

Result<RedisStore::TextonProbe> RedisStore::probe_texton(const std::string& id) {
    auto r = command({"EVAL", kProbeScript, "1", texton_key(id)});
    if (!r) return r.error();
    const std::string what = "texton " + id + " in the shared store";
    auto reply = probed(r.value()->r, 9, what);
    if (!reply) return reply.error();
    TextonProbe p;
    const redisReply* z = reply.value();
    if (!z) return p;
    p.exists = true;
    for (std::size_t i = 0; i < 3; ++i) p.len[i] = z->element[i + 1]->integer;
    if (z->element[4]->integer > 64 || z->element[5]->integer > 64 || z->element[6]->integer > 5)
        return make_error(ErrorCode::io, what + " has a checksum over 64 bytes or more than a "
                                                "texton's 5 fields; it is not read");
    p.file_sha = Reply::string(z->element[7]);
    p.png_sha = Reply::string(z->element[8]);
    p.signature = std::to_string(p.len[0]) + ":" + std::to_string(p.len[1]) + ":" +
                  std::to_string(p.len[2]) + ":" + p.file_sha.value_or("-") + ":" +
                  p.png_sha.value_or("-");
    return p;
}

// A texton is read in several commands: a value gone between them (nil) was deleted meanwhile,
// perhaps stored again; that is no damage (it had been refused and remembered for a minute). One
// that fails its checksum is refused only while the texton is still what was probed.
Result<std::optional<RedisStore::Texton>>
RedisStore::reprobe(const std::string& id, const TextonProbe& p, const std::string& why) {
    auto again = probe_texton(id);
    if (!again) return again.error();
    if (!again.value().exists) return std::optional<Texton>{};
    const std::string what = "texton " + id + " in the shared store";
    if (why.empty() || again.value().signature != p.signature)
        return make_error(ErrorCode::unavailable, what + " changed while it was read; retry");
    remember_refused(id, p.signature);
    return make_error(ErrorCode::io, what + " " + why);
}

Result<std::optional<RedisStore::Texton>> RedisStore::get(const std::string& id) {
    // Every field's size before any value is read (100 MB in `file` once cost every request 100
    // MB, and its slow read called the whole store down), its checksums' too; what a texton
    // cannot hold is refused unread, as damaged, and the store stays up. A texton refused once is
    // not read again while its sizes and checksums stay the same (for a minute at most).
    auto probe = probe_texton(id);
    if (!probe) return probe.error();
    const TextonProbe& p = probe.value();
    if (!p.exists) return std::optional<Texton>{};
    const std::string key = texton_key(id), what = "texton " + id + " in the shared store";
    if (refused_before(id, p.signature))
        return make_error(ErrorCode::io, what + " was refused before and has not changed; it is "
                                                "not read again");
    auto gone_meanwhile = [&] { return reprobe(id, p, ""); };
    auto refuse = [&](const std::string& why) { return reprobe(id, p, why); };
    auto too_big = [&](const char* name, long long n, long long cap) {
        remember_refused(id, p.signature);
        return make_error(ErrorCode::io, what + " has a " + std::string(name) + " of " +
                                             std::to_string(n) + " bytes, more than it can hold (" +
                                             std::to_string(cap) + "); it is not read");
    };
    if (p.len[0] > kMaxFileBytes) return too_big("file", p.len[0], kMaxFileBytes);
    if (p.len[2] > kMaxMetaBytes) return too_big("meta", p.len[2], kMaxMetaBytes);
    // The file and metadata (a few kB) first: the metadata's exemplar size bounds the exemplar.
    const auto small = static_cast<std::size_t>(p.len[0] + p.len[2]);
    auto lease = reserve_fetch(small);
    if (!lease) return lease.error();
    auto r = command({"HMGET", key, "file", "meta"}, small);
    if (!r) return r.error();
    const redisReply* a = r.value()->r;
    if (a->type != REDIS_REPLY_ARRAY || a->elements != 2)
        return make_error(ErrorCode::io, "unexpected Redis reply to HMGET");
    auto file = Reply::string(a->element[0]);
    std::string meta = Reply::string(a->element[1]).value_or("");
    r.value().reset();
    if (!file) return p.len[0] > 0 ? gone_meanwhile() : refuse("has no file; it is not served");
    if (!p.file_sha || io::sha256_hex(*file) != *p.file_sha)
        return refuse("fails its file checksum (damaged or half-written); it is not served");
    long long cap = 0;
    try {
        const auto j = nlohmann::json::parse(meta).at("exemplar");
        cap = exemplar_cap(j.at("width").get<long long>(), j.at("height").get<long long>());
    } catch (const std::exception&) {
        cap = 0; // no size to bound it by: only an empty exemplar is read
    }
    if (p.len[1] > cap) return too_big("exemplar", p.len[1], cap);
    auto exemplar = read_exemplar(key, p, cap);
    if (!exemplar && exemplar.error().code == ErrorCode::not_found) return gone_meanwhile();
    if (!exemplar) return exemplar.error();
    if (!*exemplar.value())
        return refuse("fails its exemplar checksum (damaged, half-written or changed while "
                      "read); it is not served");
    return std::optional<Texton>{
        Texton{std::move(*file), std::move(**exemplar.value()), std::move(meta), p.signature}};
}

// The exemplar of a probed texton, `cap` bytes at most; nullopt when it fails its checksum,
// not_found when it is gone (deleted since the probe).
Result<std::unique_ptr<std::optional<std::string>>>
RedisStore::read_exemplar(const std::string& key, const TextonProbe& p, long long cap) {
    auto out = std::make_unique<std::optional<std::string>>(std::string());
    if (p.len[1] <= 0) return out;
    auto lease = reserve_fetch(static_cast<std::size_t>(p.len[1]));
    if (!lease) return lease.error();
    auto e = command({"HGET", key, "exemplar"}, static_cast<std::size_t>(p.len[1]));
    if (!e) return e.error();
    auto png = Reply::string(e.value()->r);
    e.value().reset();
    if (!png) return make_error(ErrorCode::not_found, "the exemplar is gone"); // deleted meanwhile
    if (static_cast<long long>(png->size()) > cap || !p.png_sha ||
        io::sha256_hex(*png) != *p.png_sha)
        out->reset();
    else
        *out = std::move(*png);
    return out;
}

void RedisStore::refuse_texton(const std::string& id, const std::string& signature) {
    remember_refused(id, signature);
}

Result<RedisStore::Presence> RedisStore::presence(const std::string& id) {
    auto r = pipeline({{"EXISTS", texton_key(id)}, {"EXISTS", tombstone_key(id)}});
    if (!r) return r.error();
    if (r.value()[0]->integer() == 1) return Presence::present;
    return r.value()[1]->integer() == 1 ? Presence::deleted : Presence::unknown;
}

Result<bool> RedisStore::remove(const std::string& id) {
    forget_refused(id);
    auto r =
        command({"EVAL", kRemoveScript, "3", texton_key(id), ids_key(), tombstone_key(id), id});
    if (!r) return r.error();
    return r.value()->integer() == 1;
}

Result<std::vector<std::pair<std::string, std::string>>>
RedisStore::list_meta(const std::string& after, int limit, bool* more) {
    if (more) *more = false;
    auto ids = command({"EVAL", kListIdsScript, "1", ids_key(), after.empty() ? "-" : "(" + after,
                        std::to_string(limit)});
    if (!ids) return ids.error();
    const redisReply* a = ids.value()->r;
    if (a->type == REDIS_REPLY_ERROR) // the index is of another type: no list, not an empty one
        return make_error(ErrorCode::io, "the shared store's id index cannot be read: " +
                                             std::string(a->str, a->len));
    std::vector<std::string> listed;
    std::vector<std::vector<std::string>> lengths;
    for (std::size_t i = 0; a->type == REDIS_REPLY_ARRAY && i < a->elements; ++i)
        if (auto id = Reply::string(a->element[i])) {
            listed.push_back(*id);
            lengths.push_back({"HSTRLEN", texton_key(*id), "meta"});
        }
    std::vector<std::pair<std::string, std::string>> out;
    if (lengths.empty()) return out;
    // Each metadata's length before it is read: one over kMaxMetaBytes is skipped unread (100
    // MB under three ids once cost a list 2.6 s and 500 MB).
    auto sizes = pipeline(lengths);
    if (!sizes) return sizes.error();
    std::vector<std::string> read;
    std::vector<std::vector<std::string>> gets;
    std::size_t page = 0;
    for (std::size_t i = 0; i < listed.size(); ++i) {
        const long long n = sizes.value()[i]->integer(); // -1: a value of another type
        if (n < 0 || n > kMaxListedMetaBytes) {
            spdlog::error("store: the metadata of {} in the shared store is {} bytes (a list "
                          "takes {} at most) or no hash; not read, not listed",
                          listed[i], n, kMaxListedMetaBytes);
            continue;
        }
        // A page reads kListPageBytes at most: past it the page ends early, and `more` says the
        // list goes on after its last id (1000 ids of 1 MiB once cost a list 1 GB and 31 s).
        if (page + static_cast<std::size_t>(n) > kListPageBytes && !read.empty()) {
            if (more) *more = true;
            break;
        }
        page += static_cast<std::size_t>(n);
        read.push_back(listed[i]);
        gets.push_back({"HGET", texton_key(listed[i]), "meta"});
    }
    if (gets.empty()) return out;
    auto metas = pipeline(gets);
    if (!metas) return metas.error();
    for (std::size_t i = 0; i < metas.value().size(); ++i) {
        auto s = Reply::string(metas.value()[i]->r);
        if (s && static_cast<long long>(s->size()) <= kMaxMetaBytes) // deleted meanwhile: skip
            out.emplace_back(read[i], std::move(*s));
    }
    return out;
}

Result<bool> RedisStore::put_job(const std::string& id, const std::string& json,
                                 std::chrono::seconds ttl) {
    if (json.size() > kMaxJobBytes)
        return make_error(ErrorCode::invalid_argument, "a job's status is larger than it may be");
    auto r = command({"SET", job_key(id), json, "EX",
                      std::to_string(std::max<long long>(1, static_cast<long long>(ttl.count())))});
    if (!r) return r.error();
    return true;
}

Result<std::optional<std::string>> RedisStore::get_job(const std::string& id) {
    auto size = command({"STRLEN", job_key(id)});
    if (!size) return size.error();
    const long long n = size.value()->integer();
    if (n <= 0 || static_cast<std::size_t>(n) > kMaxJobBytes) return std::optional<std::string>();
    auto r = command({"GET", job_key(id)}, static_cast<std::size_t>(n));
    if (!r) return r.error();
    return Reply::string(r.value()->r);
}

Result<std::uint64_t> RedisStore::count() {
    auto r = command({"ZCARD", ids_key()});
    if (!r) return r.error();
    return static_cast<std::uint64_t>(std::max(0LL, r.value()->integer()));
}

Result<bool> RedisStore::up() {
    auto r = command({"PING"});
    if (!r) return r.error();
    const redisReply* p = r.value()->r;
    if (p->type != REDIS_REPLY_STATUS || std::string(p->str, p->len) != "PONG")
        return make_error(ErrorCode::unavailable, "the shared store does not answer PING with "
                                                  "PONG: not a Redis?");
    if (std::string why = write_refusal(); !why.empty())
        return make_error(ErrorCode::unavailable, "the shared store refuses writes: " + why);
    return true;
}

void RedisStore::forget_refused(const std::string& memo) {
    std::lock_guard lock(m_mutex);
    m_refused.erase(memo);
}

Result<bool> RedisStore::put_object(const std::string& kind, const std::string& id,
                                    const Files& files, bool write_back) {
    forget_refused(kind + ":" + id);
    std::vector<std::string> argv = {"EVAL", write_back ? kWriteBackObjectScript : kPutObjectScript,
                                     "2", object_key(kind, id), object_tombstone_key(kind, id)};
    for (const auto& [suffix, bytes] : files) {
        argv.push_back(suffix);
        argv.push_back(bytes);
        argv.push_back(suffix + ".sha256");
        argv.push_back(io::sha256_hex(bytes));
    }
    return write_script(argv);
}

// An object's known files sized, with their checksums' sizes, and the field count (no field name
// is read: a 200 MB name is as costly as a value), before anything is read; then the checksums.
// A splat's or mix's fields sized, and their checksums read, by one script (one version of the
// object, as the texton probe): the count of fields, then for each suffix its length, its
// checksum's length and the checksum (nil when absent or over 64 bytes).
constexpr const char* kProbeObjectScript = R"lua(
local k = KEYS[1]
if redis.call('EXISTS', k) == 0 then return {0} end
if redis.call('TYPE', k)['ok'] ~= 'hash' then return {-1} end
local out = {1, redis.call('HLEN', k)}
for _, s in ipairs(ARGV) do
  local n, m = redis.call('HSTRLEN', k, s), redis.call('HSTRLEN', k, s .. '.sha256')
  out[#out + 1] = n
  out[#out + 1] = m
  if n > 0 and m > 0 and m <= 64 then
    out[#out + 1] = redis.call('HGET', k, s .. '.sha256')
  else
    out[#out + 1] = false
  end
end
return out
)lua";

Result<RedisStore::ObjectProbe>
RedisStore::probe_object(const std::string& key, const std::string& what,
                         const std::map<std::string, long long>& caps) {
    std::vector<std::string> argv = {"EVAL", kProbeObjectScript, "1", key};
    std::vector<std::string> suffixes;
    for (const auto& [suffix, cap] : caps) {
        suffixes.push_back(suffix);
        argv.push_back(suffix);
    }
    auto r = command(argv);
    if (!r) return r.error();
    auto reply = probed(r.value()->r, 2 + 3 * suffixes.size(), what);
    if (!reply) return reply.error();
    ObjectProbe p;
    const redisReply* z = reply.value();
    if (!z) return p;
    const long long fields = z->element[1]->integer;
    long long counted = 0;
    for (std::size_t i = 0; i < suffixes.size(); ++i) {
        const long long n = z->element[2 + 3 * i]->integer;
        const long long sha = z->element[3 + 3 * i]->integer;
        counted += (n > 0) + (sha > 0);
        if (n <= 0) continue;
        if (n > caps.at(suffixes[i]) || sha > 64)
            return make_error(ErrorCode::io,
                              what + " has a " + suffixes[i] + " of " + std::to_string(n) +
                                  " bytes (checksum " + std::to_string(sha) +
                                  "), more than it can hold (" +
                                  std::to_string(caps.at(suffixes[i])) + "); it is not read");
        p.present.push_back(suffixes[i]);
        p.total += static_cast<std::size_t>(n);
        p.sums.push_back(Reply::string(z->element[4 + 3 * i]).value_or(""));
        p.signature += suffixes[i] + "=" + std::to_string(n) + ";" + p.sums.back() + ";";
    }
    if (counted != fields)
        return make_error(ErrorCode::io, what + " has " + std::to_string(fields - counted) +
                                             " fields it cannot hold; it is not read");
    return p;
}

Result<std::optional<RedisStore::Files>>
RedisStore::get_object(const std::string& kind, const std::string& id,
                       const std::map<std::string, long long>& caps, std::string* signature_out) {
    const std::string key = object_key(kind, id);
    const std::string what = kind + " " + id + " in the shared store";
    auto probe = probe_object(key, what, caps);
    if (!probe) return probe.error();
    const ObjectProbe& p = probe.value();
    if (p.present.empty()) return std::optional<Files>{};
    if (signature_out) *signature_out = p.signature;
    const std::string memo = kind + ":" + id;
    if (refused_before(memo, p.signature))
        return make_error(ErrorCode::io, what + " was refused before and has not changed; it is "
                                                "not read again");
    auto lease = reserve_fetch(p.total);
    if (!lease) return lease.error();
    Files out;
    for (std::size_t i = 0; i < p.present.size(); ++i) { // one at a time: one copy in flight
        auto r = command({"HGET", key, p.present[i]}, p.total);
        if (!r) return r.error();
        auto bytes = Reply::string(r.value()->r);
        r.value().reset();
        if (!bytes) return std::optional<Files>{}; // removed meanwhile
        if (static_cast<long long>(bytes->size()) > caps.at(p.present[i]) ||
            io::sha256_hex(*bytes) != p.sums[i]) {
            // Stored again between the probe and this read: no damage.
            auto again = probe_object(key, what, caps);
            if (again && again.value().present.empty()) return std::optional<Files>{};
            if (again && again.value().signature != p.signature)
                return make_error(ErrorCode::unavailable,
                                  what + " changed while it was read; retry");
            remember_refused(memo, p.signature);
            return make_error(ErrorCode::io, what + " fails its " + p.present[i] +
                                                 " checksum (damaged or half-written); it is "
                                                 "not served");
        }
        out.emplace(p.present[i], std::move(*bytes));
    }
    return std::optional<Files>{std::move(out)};
}

void RedisStore::refuse_object(const std::string& kind, const std::string& id,
                               const std::string& signature) {
    remember_refused(kind + ":" + id, signature);
}

Result<RedisStore::Presence> RedisStore::object_presence(const std::string& kind,
                                                         const std::string& id) {
    auto r =
        pipeline({{"EXISTS", object_key(kind, id)}, {"EXISTS", object_tombstone_key(kind, id)}});
    if (!r) return r.error();
    if (r.value()[0]->integer() == 1) return Presence::present;
    return r.value()[1]->integer() == 1 ? Presence::deleted : Presence::unknown;
}

Result<bool> RedisStore::remove_object(const std::string& kind, const std::string& id) {
    forget_refused(kind + ":" + id);
    auto r = command(
        {"EVAL", kRemoveObjectScript, "2", object_key(kind, id), object_tombstone_key(kind, id)});
    if (!r) return r.error();
    return r.value()->integer() == 1;
}

RedisStore::Health RedisStore::health() {
    auto up = this->up();
    // A full (or evicting) Redis is seen before a write fails, by its own figures, so that a
    // replica that has not written yet reports it too.
    if (!up) return {false, up.error().message};
    return {true, memory_warning()};
}

std::optional<std::string> RedisStore::memory_warning() {
    auto r = command({"INFO", "memory"});
    if (!r) return r.error().message;
    const redisReply* v = r.value()->r;
    if (v->type != REDIS_REPLY_STRING || !v->str) return "the store does not answer INFO memory";
    const std::string info(v->str, v->len);
    auto field = [&](const std::string& name) -> std::string {
        const auto at = info.find("\n" + name + ":");
        if (at == std::string::npos) return "";
        const auto from = at + name.size() + 2;
        return info.substr(from, info.find_first_of("\r\n", from) - from);
    };
    const std::string policy = field("maxmemory_policy");
    if (!policy.empty() && policy != "noeviction")
        return "Redis evicts keys (maxmemory-policy " + api::printable(policy, 40) +
               "): textons, splats and mixes would be lost; set noeviction";
    // Redis's own decimal integers; anything else reads as 0 (no limit known).
    const long long max = std::strtoll(field("maxmemory").c_str(), nullptr, 10);
    const long long used = std::strtoll(field("used_memory").c_str(), nullptr, 10);
    // Full once less than 5% or 16 MiB is left: the next texton with its exemplar may not fit.
    if (max > 0 && used > max - std::max(max / 20, 16LL << 20))
        return "Redis is nearly full: " + std::to_string(used) + " of " + std::to_string(max) +
               " bytes (maxmemory) used";
    return std::nullopt;
}

} // namespace textond::store
