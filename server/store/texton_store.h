#pragma once
// The textons the service serves: this replica's TextonDirectory (texton_directory.h: the files,
// atomic writes, verification, quarantine) and the prepared textons of recent renders.
//
// With a shared store (`--store redis://...`, server/store/redis_store.h) the directory is a
// read-through cache of it: a texton this replica lacks is fetched, verified and kept; a texton
// analysed here is written there first (write-once: when another replica stored the same id
// first, that one is adopted). A local copy is rechecked against the shared store at most every
// `recheck` (deleted elsewhere: dropped here; missing there, e.g. a flushed Redis: written back).
// While the shared store is down, local copies keep being served and writes fail with
// ErrorCode::unavailable.
#include "api/texton_meta.h"
#include "core/result.h"
#include "render/prepared_texton.h"
#include "server/io/texton_file.h"
#include "server/store/in_flight.h"
#include "server/store/periodic_sweep.h"
#include "server/store/redis_store.h"
#include "server/store/single_flight.h"
#include "server/store/texton_directory.h"

#include <chrono>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace textond::store {

class TextonStore {
public:
    // Opens the directory (creating it, removing the temporary files a crash left).
    static Result<std::unique_ptr<TextonStore>>
    open(const std::string& data_dir, std::size_t prepared_cache = 64,
         std::unique_ptr<store::RedisStore> shared = nullptr,
         std::chrono::milliseconds recheck = std::chrono::seconds(30),
         std::size_t meta_cache = TextonDirectory::kDefaultMetaCache);
    TextonStore(const TextonStore&) = delete;
    TextonStore& operator=(const TextonStore&) = delete;

    // The texton's metadata: local, else fetched from the shared store. not_found, or
    // unavailable when only the (unreachable) shared store could tell.
    // `now`: a local copy is rechecked against the shared store now, not within --store-recheck-s
    // (an upload must not answer "stored already" for a texton another replica deleted).
    Result<api::TextonMeta> find(const std::string& id, bool now = false);
    // Verified and ready to render; kept in a small LRU of prepared textons.
    Result<std::shared_ptr<const render::PreparedTexton>> prepared(const std::string& id);
    // The file read and verified (fetched first when only the shared store holds it).
    Result<io::TextonRecord> record(const std::string& id);
    // The stored file's bytes (GET .../texton.exr), verified first.
    Result<std::string> file_bytes(const std::string& id);

    // Stores a new texton (and its exemplar when given); `created` is set here. Returns false
    // when it already existed.
    Result<bool> put(io::TextonRecord record, const core::Image* exemplar = nullptr);
    // The stored exemplar PNG, or not_found.
    Result<std::string> exemplar_png(const std::string& id);
    // The exemplar decoded; a stored one that does not decode is an io error (500), not the
    // client's (422 or 413: it was admitted when it was uploaded, so only --max-pixels's bound of
    // 2^32 applies).
    Result<core::Image> exemplar_image(const std::string& id);
    // exemplar_png once its bytes have decoded in this process (the first request decodes them):
    // a damaged exemplar is never served as one.
    Result<std::string> verified_exemplar_png(const std::string& id);
    Result<bool> remove(const std::string& id);

    // Ids in ascending order after `after` (exclusive), at most `limit`: the shared store's when
    // there is one.
    // `resume`, when given, receives the id after which the list goes on when the page ended
    // before `limit` for its byte budget (RedisStore::list_meta), else "".
    Result<std::vector<api::TextonMeta>> list(const std::string& after, int limit,
                                              std::string* resume = nullptr);
    Result<std::uint64_t> total();
    // This replica's copy (counts, size, quarantine, the readiness probe).
    const TextonDirectory& local() const { return *m_local; }
    store::RedisStore* shared() const { return m_shared.get(); }

private:
    TextonStore(std::unique_ptr<TextonDirectory> local, std::size_t prepared_cache,
                std::unique_ptr<store::RedisStore> shared, std::chrono::milliseconds recheck);
    Result<api::TextonMeta> fetch_shared(const std::string& id);
    Result<api::TextonMeta> fetch_shared_once(const std::string& id);
    Result<api::TextonMeta> recheck(const std::string& id, api::TextonMeta local);
    // Drops what this object remembers of a texton the directory no longer holds.
    void forget(const std::string& id);
    // Every --store-recheck-s, every held texton is rechecked against the shared store: written
    // back when missing there (a flushed Redis: all of them, not only those asked for), dropped
    // when deleted there.
    // The stored exemplar's bytes decoded (any failure an io error), and marked as decoding.
    Result<core::Image> decode_exemplar(const std::string& id, const std::string& png);
    void sweep();

    const std::unique_ptr<TextonDirectory> m_local;
    const std::size_t m_prepared_capacity;
    const std::unique_ptr<store::RedisStore> m_shared;
    const std::chrono::milliseconds m_recheck;
    mutable std::mutex m_mutex; // may be held while calling m_local, never taken inside it
    std::map<std::string, std::chrono::steady_clock::time_point> m_checked; // against m_shared
    std::set<std::string> m_exemplars_decoded;                              // verified_exemplar_png
    // Uploads between their local write and their own store in m_shared: not written back by a
    // recheck meanwhile (which had made a fresh upload answer 200, "stored before").
    InFlightIds m_creating;
    // Most recently used first.
    std::list<std::pair<std::string, std::shared_ptr<const render::PreparedTexton>>> m_prepared;
    SingleFlight<Result<api::TextonMeta>> m_fetches; // from the shared store, one an id
    std::optional<PeriodicSweep> m_sweeper; // with a shared store only; last, stopped first
};

} // namespace textond::store
