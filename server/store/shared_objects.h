#pragma once
// Splats and mixes in the shared store, as textons are: the replica that creates
// one writes its files there once (write-once: a second creator finds it stored), a replica that
// lacks one fetches its files into its own directory, where the usual reader checks them, and a
// removal leaves a tombstone that every other replica sees within --store-recheck-s. The files
// are those of server/io/splat_file.h and server/io/mix_file.h, named by suffix; each has a cap
// checked before a byte of it is read. Without a shared store every call is a no-op.
#include "core/result.h"
#include "server/store/in_flight.h"
#include "server/store/periodic_sweep.h"
#include "server/store/redis_store.h"
#include "server/store/single_flight.h"

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::store {

// <data_dir>/<name>, the directory of one kind of object (mixes, splats): made if missing, and
// rid of the temporaries of writes a crash interrupted (a kill -9 mid-write had left a 40 MB one
// for good), before the store that opens it writes or sweeps.
Result<std::string> open_object_directory(const std::string& data_dir, const std::string& name);

class SharedObjects {
public:
    struct File {
        std::string suffix; // "<id><suffix>" in the directory
        long long cap;      // most bytes it can hold
    };
    // `files` in writing order: the last is the one whose presence says the object is whole.
    // With a shared store, a thread looks at every held object once a recheck interval and
    // writes back those the store has lost (a flushed Redis), as TextonStore's sweep does: a
    // replica that was never asked for one had left it 404 on every other replica.
    SharedObjects(RedisStore* shared, std::string kind, std::string dir, std::vector<File> files,
                  std::chrono::milliseconds recheck);
    SharedObjects(const SharedObjects&) = delete;
    SharedObjects& operator=(const SharedObjects&) = delete;

    bool enabled() const { return m_shared != nullptr; }
    // This replica's copy is whole (its main file, the last of `files`, is there).
    bool held(const std::string& id) const;
    // Held here and not deleted elsewhere (asked now: a creation after a delete elsewhere must
    // store again, where it answered 200 and stored nothing), or fetched. A copy deleted elsewhere
    // is erased and `dropped` called (the store forgets what it prepared of it).
    bool contains(const std::string& id, const std::function<void()>& dropped);
    // Gone from the shared store (a tombstone) and from this replica: whether either held it.
    Result<bool> remove_everywhere(const std::string& id);
    // The local files just written, stored in the shared store too (false: already there).
    // With `write_back` (a copy held here that the store lost) nothing is stored over a
    // tombstone, and nothing while the id is being created here (creating()).
    Result<bool> publish(const std::string& id, bool write_back = false);
    // Ids being created here: a store marks one (InFlightIds::Mark) from before its local files
    // until its own publish, so that no write-back stores it first (the creation had answered
    // 200).
    InFlightIds& creations() { return m_creating; }
    // The object's files fetched into the directory (one fetch an id at a time): false when the
    // shared store has none (or a tombstone), unavailable when it cannot say.
    Result<bool> fetch(const std::string& id);
    // A local copy was deleted in the shared store (asked at most every recheck an id, or now
    // when `now`: before a creation answers that it is stored already).
    bool deleted_elsewhere(const std::string& id, bool now = false);
    // The copy just fetched failed the reader's checks: its files go, and the shared store's
    // values are not read again until they change.
    void reject(const std::string& id);
    // Removed from the shared store, leaving a tombstone: false when it was not there.
    Result<bool> remove(const std::string& id);
    // The local files, as a removal leaves them: gone.
    void erase_local(const std::string& id) const;

private:
    Result<bool> fetch_once(const std::string& id);
    void sweep();
    RedisStore* const m_shared;
    const std::string m_kind, m_dir;
    const std::vector<File> m_files;
    const std::chrono::milliseconds m_recheck;
    std::mutex m_mutex;
    std::map<std::string, std::chrono::steady_clock::time_point> m_checked;
    SingleFlight<Result<bool>> m_fetches;
    std::map<std::string, std::string> m_fetched_signature; // of the values last fetched, by id
    InFlightIds m_creating;
    std::optional<PeriodicSweep> m_sweeper; // with a shared store only; last, stopped first
};

} // namespace textond::store
