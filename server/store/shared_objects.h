#pragma once
// Splats and mixes in the shared store (issue 43 item 1), as textons are: the replica that creates
// one writes its files there once (write-once: a second creator finds it stored), a replica that
// lacks one fetches its files into its own directory, where the usual reader checks them, and a
// removal leaves a tombstone that every other replica sees within --store-recheck-s. The files
// are those of server/io/splat_file.h and server/io/mix_file.h, named by suffix; each has a cap
// checked before a byte of it is read. Without a shared store every call is a no-op.
#include "core/result.h"
#include "server/store/redis_store.h"

#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::store {

class SharedObjects {
public:
    struct File {
        std::string suffix; // "<id><suffix>" in the directory
        long long cap;      // most bytes it can hold
    };
    // `files` in writing order: the last is the one whose presence says the object is whole.
    SharedObjects(RedisStore* shared, std::string kind, std::string dir, std::vector<File> files,
                  std::chrono::milliseconds recheck);

    bool enabled() const { return m_shared != nullptr; }
    // The local files just written, stored in the shared store too (false: already there).
    Result<bool> publish(const std::string& id);
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
    RedisStore* const m_shared;
    const std::string m_kind, m_dir;
    const std::vector<File> m_files;
    const std::chrono::milliseconds m_recheck;
    std::mutex m_mutex;
    std::map<std::string, std::chrono::steady_clock::time_point> m_checked;
    struct Fetch {
        std::optional<Result<bool>> result;
    };
    std::map<std::string, std::shared_ptr<Fetch>> m_fetching;
    std::map<std::string, std::string> m_fetched_signature; // of the values last fetched, by id
    std::condition_variable m_fetched;
};

} // namespace textond::store
