#pragma once
// Splat maps on local disk (`<data>/splats/`, see server/io/splat_file.h), content addressed, with
// a small LRU of prepared splats (at most 16, and 256 MB of weight images). A splat names its
// layers (and a rules height) by texton id and takes them from the texton store when it is
// prepared (fetching them from the shared store like any texton): one whose texton was deleted
// answers not_found until the texton is uploaded again (the same id). With --store, splats are
// shared as textons are (shared_objects.h): written there on creation, fetched by a replica that
// lacks one, and deleted everywhere.
#include "core/result.h"
#include "render/prepared_splat.h"
#include "server/io/splat_file.h"
#include "server/store/bounded_lru.h"
#include "server/store/load_limit.h"
#include "server/store/quarantine.h"
#include "server/store/shared_objects.h"
#include "server/store/single_flight.h"
#include "server/store/texton_store.h"

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::store {

class SplatStore {
public:
    static Result<std::unique_ptr<SplatStore>>
    open(const std::string& data_dir, TextonStore& textons,
         std::chrono::milliseconds recheck = std::chrono::seconds(30));

    // Held here, or fetched from the shared store.
    bool contains(const std::string& id);
    // Gone here and from the shared store (a tombstone); not_found when neither held it.
    Result<bool> remove(const std::string& id);
    Result<api::SplatMeta> meta(const std::string& id);
    Result<std::shared_ptr<const render::PreparedSplat>> prepared(const std::string& id);
    // The record made ready: its layers (and height) from the texton store, validated. What
    // creation checks before anything is written.
    Result<std::shared_ptr<const render::PreparedSplat>> prepare(const io::SplatRecord& record);
    // Writes the files (atomically); false when the splat was already there.
    Result<bool> put(const io::SplatRecord& record);
    // Splats whose files were damaged or failed today's rules at load, moved to
    // <data>/splats/quarantine/ (by this run or an earlier one).
    std::vector<std::string> quarantined() const; // the first QuarantineList::kListed by name
    std::size_t quarantined_count() const;

private:
    struct Entry {
        std::string id;
        api::SplatMeta meta;
        std::shared_ptr<const render::PreparedSplat> prepared;
        std::size_t bytes = 0; // its weight image
    };
    // not_found when a layer (or the rules' height) is no longer stored.
    std::optional<Error> layers_stored(const api::SplatMeta& meta);
    SplatStore(std::string dir, TextonStore& textons, std::chrono::milliseconds recheck);
    Result<Entry> load(const std::string& id);
    std::optional<Entry> kept(const std::string& id); // from the LRU, made most recent
    Result<Entry> load_files(const std::string& id);  // fetched, read, prepared and kept
    void forget(const std::string& id);
    void quarantine(const std::string& id, const std::string& why);
    std::string m_dir;
    TextonStore& m_textons;
    SharedObjects m_shared;
    mutable std::mutex m_mutex;
    std::mutex m_put_mutex;
    QuarantineList m_quarantined;
    BoundedLru<Entry> m_kept{kCapacity, kBudgetBytes}; // prepared, in memory
    SingleFlight<Result<Entry>> m_loads;
    LoadLimit m_limit{1}; // one splat's weight images decoded at a time (192 MiB at most)
    static constexpr std::chrono::seconds kLoadWait{30};
    static constexpr std::size_t kCapacity = 16;
    static constexpr std::size_t kBudgetBytes = std::size_t{256} << 20; // weight images kept
};

} // namespace textond::store
