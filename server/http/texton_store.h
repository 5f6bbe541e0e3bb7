#pragma once
// Textons on disk, content-addressed: <data>/textons/<id>.exr (the texton file of
// api/TEXTON_FORMAT.md), and the exemplar it came from as <data>/exemplars/<id>.png (8-bit, for
// people and the quality panel; written before the texton, so a texton has its exemplar unless it
// predates them). Writes are atomic (temporary file, fsync, rename, fsync of the
// directory), so after a crash a texton is complete or absent. Every file is verified (metadata,
// coefficient checksum, id = file name) when the store opens and again whenever it is loaded; a
// file that fails is moved to <data>/quarantine/ and reported, never served. Ids are checked
// against ^[0-9a-f]{64}$ before they are joined to a path.
#include "api/texton_meta.h"
#include "core/result.h"
#include "render/prepared_texton.h"
#include "server/io/texton_file.h"

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
    static Result<std::unique_ptr<TextonStore>> open(const std::string& data_dir,
                                                     std::size_t prepared_cache = 64);

    std::optional<api::TextonMeta> meta(const std::string& id) const;
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
    Result<std::string> exemplar_png(const std::string& id) const;
    Result<bool> remove(const std::string& id);

    // Ids in ascending order after `after` (exclusive), at most `limit`.
    std::vector<api::TextonMeta> list(const std::string& after, int limit) const;
    std::size_t count() const;
    std::uint64_t bytes() const;
    std::vector<std::string> quarantined() const; // file names moved aside since start
    // Can we create a file in the store right now? (readiness probe)
    bool writable() const;

private:
    explicit TextonStore(std::string dir, std::size_t prepared_cache);
    std::string path_of(const std::string& id) const;
    std::string exemplar_path_of(const std::string& id) const;
    void quarantine_locked(const std::string& id, const std::string& why);
    Result<io::TextonRecord> load_verified(const std::string& id);

    const std::string m_dir, m_exemplars, m_quarantine;
    const std::size_t m_prepared_capacity;
    mutable std::mutex m_mutex;
    std::map<std::string, api::TextonMeta> m_index;
    std::map<std::string, std::uint64_t> m_sizes;
    std::vector<std::string> m_quarantined;
    // Most recently used first.
    std::list<std::pair<std::string, std::shared_ptr<const render::PreparedTexton>>> m_prepared;
};

} // namespace textond::http
