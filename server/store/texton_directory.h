#pragma once
// This replica's copy of the textons, content-addressed: <data>/textons/<id>.exr (the texton file
// of api/TEXTON_FORMAT.md), the exemplar it came from as <data>/exemplars/<id>.png (8-bit, for
// people and the quality panel; written before the texton, so a texton has its exemplar unless it
// predates them), and how this copy came to be (`created`, the analysis' `timings_ms`) as
// <data>/provenance/<id>.json, outside the file so that the file is the same bytes whoever analysed
// it. Writes are atomic (temporary file, fsync, rename, fsync of the directory), so after a crash a
// texton is complete or absent.
//
// Opening starts a scan of the file names on a thread of its own, so readiness does not wait on
// the store's size: until it ends, an id not seen yet is looked up on disk, and a listing waits
// for it (a few microseconds a texton). A file is verified (metadata, coefficient checksum, id =
// file name) the first time its metadata is asked for and again whenever it is loaded, and one that
// fails is moved to <data>/quarantine/ and reported, never served. Memory: the sorted ids (about
// 100 bytes a texton, which is what keeps a listing paginated by id without touching the disk) and
// the metadata of at most `meta_cache` textons, most recently used. Ids are checked against
// ^[0-9a-f]{64}$ before they are joined to a path. TextonStore (texton_store.h) adds the shared
// store and the prepared textons on top.
#include "api/texton_meta.h"
#include "core/result.h"
#include "server/io/texton_file.h"
#include "server/store/quarantine.h"

#include <nlohmann/json.hpp>

#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

namespace textond::store {

class TextonDirectory {
public:
    static constexpr std::size_t kDefaultMetaCache = 10000;
    // Creates the directories, removes temporary files left by a crash and indexes the rest by
    // name.
    static Result<std::unique_ptr<TextonDirectory>>
    open(const std::string& data_dir, std::size_t meta_cache = kDefaultMetaCache);
    ~TextonDirectory();
    TextonDirectory(const TextonDirectory&) = delete;
    TextonDirectory& operator=(const TextonDirectory&) = delete;
    // Blocks until the scan of the names has ended (listings call it; so may tests).
    void wait_indexed() const;

    // Verified on first sight (a file that fails is quarantined: nullopt), then cached.
    std::optional<api::TextonMeta> meta(const std::string& id);
    // A file of that name is held (not yet verified, perhaps).
    bool contains(const std::string& id);
    // The file read and verified; a file that fails is quarantined (not_found).
    Result<io::TextonRecord> load(const std::string& id);
    // The stored bytes, unverified (not_found when absent).
    Result<std::string> file(const std::string& id) const;
    Result<std::string> exemplar(const std::string& id) const;

    // Writes a texton file (its exemplar and provenance first), verifies it like every load, then
    // indexes it. An empty `provenance` removes an older one. A file that fails verification is
    // unprocessable (the bytes are at fault); the disk's own failures are io or no_space.
    Result<bool> write(const std::string& id, const std::string& file,
                       const std::string* exemplar_png, const nlohmann::json& provenance);
    // Removes the texton and what came with it; false when it was not held. When its file
    // cannot be removed: an error, and the texton stays held, unless `regardless` (deleted
    // elsewhere: never served here again; a restart indexes the file and rechecks it).
    Result<bool> erase(const std::string& id, bool regardless = false);

    // Ids in ascending order after `after` (exclusive), at most `limit`: the metadata of verified
    // files (a damaged one is quarantined and passed over).
    std::vector<api::TextonMeta> list(const std::string& after, int limit);
    // The ids alone, unverified.
    std::vector<std::string> ids(const std::string& after, int limit) const;
    std::size_t count() const; // so far, while the scan runs
    std::uint64_t bytes() const;
    // Names of the files in <data>/quarantine/, moved aside by this run or an earlier one.
    std::vector<std::string> quarantined() const; // the first QuarantineList::kListed by name
    std::size_t quarantined_count() const;
    // Can we create a file here right now? (readiness probe)
    bool writable() const;
    // Bytes the data directory's filesystem has left for us (statvfs); nullopt when it cannot say.
    std::optional<std::uint64_t> free_bytes() const;
    const std::string& path() const { return m_dir; }

private:
    TextonDirectory(const std::string& data_dir, std::size_t meta_cache);
    // False when the file was already gone (removed outside the server): forgotten, not counted.
    bool quarantine_locked(const std::string& id, const std::string& why);
    void remember_locked(const std::string& id, api::TextonMeta meta);
    void drop_locked(const std::string& id); // from the index and the cache
    void scan();                             // the names, then what crashes left
    bool index_names(std::size_t& names);    // false when the listing failed
    void clear_orphans();
    // Older than this process, by the filesystem's clock (m_opened).
    bool left_by_a_crash(const std::filesystem::directory_entry& e) const;
    // Indexes the file of `id` when it is on disk (the scan's step, and a lookup's before the
    // scan has reached it); false when there is none.
    bool index_locked(const std::string& id);
    // The generation of the file of `id` held now; 0 when none.
    std::uint64_t generation_locked(const std::string& id) const;

    const std::string m_dir, m_exemplars, m_provenance, m_quarantine;
    const std::size_t m_meta_capacity;
    mutable std::mutex m_mutex;
    struct File {
        std::uint64_t bytes = 0;
        // Which write of the id this is: a read that began on an older one must not
        // quarantine the newer (an upload that replaced a damaged copy).
        std::uint64_t generation = 0;
    };
    std::map<std::string, File> m_files;
    std::uint64_t m_generations = 0;
    std::vector<std::string> m_writing; // ids whose files are being written now
    // An id in m_writing for a scope: the scan's clean-up leaves its exemplar and provenance be.
    class WritingMark {
    public:
        WritingMark(TextonDirectory& d, const std::string& id);
        ~WritingMark();
        WritingMark(const WritingMark&) = delete;
        WritingMark& operator=(const WritingMark&) = delete;

    private:
        TextonDirectory& m_d;
        const std::string& m_id;
    };
    std::uint64_t m_bytes = 0;
    struct Cached {
        api::TextonMeta meta;
        std::list<std::string>::iterator age;
    };
    std::unordered_map<std::string, Cached> m_meta;
    std::list<std::string> m_ages; // most recently used first
    QuarantineList m_quarantined;
    bool m_indexed = false, m_stopping = false;
    std::optional<std::filesystem::file_time_type> m_opened; // the scan's start, on disk
    mutable std::condition_variable m_indexed_cv;
    std::thread m_scanner;
};

} // namespace textond::store
