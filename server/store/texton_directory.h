#pragma once
// This replica's copy of the textons, content-addressed: <data>/textons/<id>.exr (the texton file
// of api/TEXTON_FORMAT.md), the exemplar it came from as <data>/exemplars/<id>.png (8-bit, for
// people and the quality panel; written before the texton, so a texton has its exemplar unless it
// predates them), and how this copy came to be (`created`, the analysis' `timings_ms`) as
// <data>/provenance/<id>.json, outside the file so that the file is the same bytes whoever analysed
// it. Writes are atomic (temporary file, fsync, rename, fsync of the directory), so after a crash a
// texton is complete or absent. Every file is verified (metadata, coefficient checksum, id = file
// name) when the directory opens and again whenever it is loaded; a file that fails is moved to
// <data>/quarantine/ and reported, never served. Ids are checked against ^[0-9a-f]{64}$ before
// they are joined to a path. TextonStore (texton_store.h) adds the shared store and the prepared
// textons on top.
#include "api/texton_meta.h"
#include "core/result.h"
#include "server/io/texton_file.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::store {

class TextonDirectory {
public:
    // Creates the directories, removes temporary files left by a crash and indexes the rest.
    static Result<std::unique_ptr<TextonDirectory>> open(const std::string& data_dir);

    std::optional<api::TextonMeta> meta(const std::string& id) const;
    bool contains(const std::string& id) const;
    // The file read and verified; a file that fails is quarantined (not_found).
    Result<io::TextonRecord> load(const std::string& id);
    // The stored bytes, unverified (not_found when absent).
    Result<std::string> file(const std::string& id) const;
    Result<std::string> exemplar(const std::string& id) const;

    // Writes a texton file (its exemplar and provenance first), verifies it like every load, then
    // indexes it. An empty `provenance` removes an older one.
    Result<bool> write(const std::string& id, const std::string& file,
                       const std::string* exemplar_png, const nlohmann::json& provenance);
    // Removes the texton and what came with it; false when it was not held. When its file
    // cannot be removed: an error, and the texton stays held, unless `regardless` (deleted
    // elsewhere: never served here again; a restart indexes the file and rechecks it).
    Result<bool> erase(const std::string& id, bool regardless = false);

    // Ids in ascending order after `after` (exclusive), at most `limit`.
    std::vector<api::TextonMeta> list(const std::string& after, int limit) const;
    std::size_t count() const;
    std::uint64_t bytes() const;
    std::vector<std::string> quarantined() const; // file names moved aside since start
    // Can we create a file here right now? (readiness probe)
    bool writable() const;
    const std::string& path() const { return m_dir; }

private:
    explicit TextonDirectory(const std::string& data_dir);
    void quarantine_locked(const std::string& id, const std::string& why);

    const std::string m_dir, m_exemplars, m_provenance, m_quarantine;
    mutable std::mutex m_mutex;
    std::map<std::string, api::TextonMeta> m_index;
    std::map<std::string, std::uint64_t> m_sizes;
    std::vector<std::string> m_quarantined;
};

} // namespace textond::store
