#pragma once
// Textons on disk, content-addressed: <data>/textons/<id>.exr (the texton file of
// api/TEXTON_FORMAT.md), and the exemplar it came from as <data>/exemplars/<id>.png (8-bit, for
// people and the quality panel; written before the texton, so a texton has its exemplar unless it
// predates them), and how this copy came to be (`created`, the analysis' `timings_ms`) as
// <data>/provenance/<id>.json, outside the file so that the file is the same bytes whoever analysed
// it. Writes are atomic (temporary file, fsync, rename, fsync of the
// directory), so after a crash a texton is complete or absent. Every file is verified (metadata,
// coefficient checksum, id = file name) when the store opens and again whenever it is loaded; a
// file that fails is moved to <data>/quarantine/ and reported, never served. Ids are checked
// against ^[0-9a-f]{64}$ before they are joined to a path.
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
#include "server/store/redis_store.h"

#include <chrono>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::http {

class TextonStore {
public:
    // Creates the directories, removes temporary files left by a crash and loads the index.
    static Result<std::unique_ptr<TextonStore>>
    open(const std::string& data_dir, std::size_t prepared_cache = 64,
         std::unique_ptr<store::RedisStore> shared = nullptr,
         std::chrono::milliseconds recheck = std::chrono::seconds(30));

    // The texton's metadata: local, else fetched from the shared store. not_found, or
    // unavailable when only the (unreachable) shared store could tell.
    Result<api::TextonMeta> find(const std::string& id);
    // Held locally (no shared store lookup).
    bool contains(const std::string& id) const;
    // Verified and ready to render; kept in a small LRU of prepared textons.
    Result<std::shared_ptr<const render::PreparedTexton>> prepared(const std::string& id);
    Result<io::TextonRecord> record(const std::string& id);
    // The stored file's bytes (GET .../texton.exr), verified first.
    Result<std::string> file_bytes(const std::string& id);

    // Stores a new texton (and its exemplar when given); `created` is set here. Returns false
    // when it already existed.
    Result<bool> put(io::TextonRecord record, const core::Image* exemplar = nullptr);
    // The stored exemplar PNG, or not_found.
    Result<std::string> exemplar_png(const std::string& id);
    Result<bool> remove(const std::string& id);

    // Ids in ascending order after `after` (exclusive), at most `limit`: the shared store's when
    // there is one.
    Result<std::vector<api::TextonMeta>> list(const std::string& after, int limit);
    Result<std::uint64_t> total();
    std::size_t count() const; // held locally
    std::uint64_t bytes() const;
    std::vector<std::string> quarantined() const; // file names moved aside since start
    // Can we create a file in the store right now? (readiness probe)
    bool writable() const;
    store::RedisStore* shared() const { return m_shared.get(); }

private:
    TextonStore(const std::string& dir, std::size_t prepared_cache,
                std::unique_ptr<store::RedisStore> shared, std::chrono::milliseconds recheck);
    Result<api::TextonMeta> fetch_shared(const std::string& id);
    Result<api::TextonMeta> recheck(const std::string& id, api::TextonMeta local);
    Result<bool> write_local(const std::string& id, const std::string& file,
                             const std::string* exemplar_png,
                             const nlohmann::json& provenance = nlohmann::json::object());
    void drop_local_locked(const std::string& id);
    std::string path_of(const std::string& id) const;
    std::string exemplar_path_of(const std::string& id) const;
    std::string provenance_path_of(const std::string& id) const;
    // The file's metadata with this copy's provenance added when there is one.
    api::TextonMeta with_provenance(const std::string& id, api::TextonMeta meta) const;
    void quarantine_locked(const std::string& id, const std::string& why);
    Result<io::TextonRecord> load_verified(const std::string& id);

    const std::string m_dir, m_exemplars, m_provenance, m_quarantine;
    const std::size_t m_prepared_capacity;
    const std::unique_ptr<store::RedisStore> m_shared;
    const std::chrono::milliseconds m_recheck;
    mutable std::mutex m_mutex;
    std::map<std::string, api::TextonMeta> m_index;
    std::map<std::string, std::uint64_t> m_sizes;
    std::map<std::string, std::chrono::steady_clock::time_point> m_checked; // against m_shared
    std::vector<std::string> m_quarantined;
    // Most recently used first.
    std::list<std::pair<std::string, std::shared_ptr<const render::PreparedTexton>>> m_prepared;
};

} // namespace textond::http
