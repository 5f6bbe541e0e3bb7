#pragma once
// Texture mixes on local disk (`<data>/mixes/`, see server/io/mix_file.h), content addressed like
// textons, with a small LRU of prepared mixes (at most 8, and 128 MB of masks and levels). With
// --store they are shared as textons are (shared_objects.h): written there on creation, fetched
// by a replica that lacks one, and deleted everywhere.
#include "core/result.h"
#include "render/prepared_mix.h"
#include "server/io/mix_file.h"
#include "server/store/bounded_lru.h"
#include "server/store/load_limit.h"
#include "server/store/quarantine.h"
#include "server/store/shared_objects.h"
#include "server/store/single_flight.h"

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::store {

class MixStore {
public:
    static Result<std::unique_ptr<MixStore>>
    open(const std::string& data_dir, RedisStore* shared = nullptr,
         std::chrono::milliseconds recheck = std::chrono::seconds(30));

    // Held here, or fetched from the shared store.
    bool contains(const std::string& id);
    // Gone here and from the shared store (a tombstone); not_found when neither held it.
    Result<bool> remove(const std::string& id);
    Result<api::MixMeta> meta(const std::string& id);
    Result<std::shared_ptr<const render::PreparedMix>> prepared(const std::string& id);
    // The metadata and levels of a mix held here or fetched, read from its files without its
    // field, neither prepared nor kept (io::read_mix_files with levels_only).
    Result<io::MixRecord> levels(const std::string& id);
    // Writes the files (atomically); false when the mix was already there.
    Result<bool> put(const io::MixRecord& record);
    // Mixes whose files were damaged or failed today's validation at load, moved to
    // <data>/mixes/quarantine/ instead of being rendered (by this run or an earlier one).
    std::vector<std::string> quarantined() const; // the first QuarantineList::kListed by name
    std::size_t quarantined_count() const;

private:
    struct Entry {
        std::string id;
        api::MixMeta meta;
        std::shared_ptr<const render::PreparedMix> prepared;
        std::size_t bytes = 0; // its mask and levels
    };
    MixStore(std::string dir, RedisStore* shared, std::chrono::milliseconds recheck);
    Result<Entry> load(const std::string& id);
    std::optional<Entry> kept(const std::string& id); // from the LRU, made most recent
    Result<Entry> load_files(const std::string& id);  // fetched, read, prepared and kept
    void forget(const std::string& id);
    void quarantine(const std::string& id, const std::string& why);
    std::string m_dir;
    SharedObjects m_shared;
    mutable std::mutex m_mutex;
    QuarantineList m_quarantined;
    BoundedLru<Entry> m_kept{kCapacity, kBudgetBytes}; // prepared, in memory
    SingleFlight<Result<Entry>> m_loads;
    LoadLimit m_limit{1}; // one mask decoded at a time (16 bytes a pixel, 256 MiB at most)
    static constexpr std::chrono::seconds kLoadWait{30};
    static constexpr std::size_t kCapacity = 8;
    static constexpr std::size_t kBudgetBytes = std::size_t{128} << 20; // masks and levels kept
};

} // namespace textond::store
