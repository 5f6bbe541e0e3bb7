#pragma once
// Splat maps on local disk (`<data>/splats/`, see server/io/splat_file.h), content addressed, with
// a small LRU of prepared splats (at most 16, and 256 MB of weight images). A splat names its
// layers (and a rules height) by texton id and takes them from the texton store when it is
// prepared: one whose texton was deleted answers not_found until the texton is uploaded again (the
// same id). Like mixes, not shared through
// --store: a replica that lacks a splat answers 404 and the client creates it there (same id).
#include "core/result.h"
#include "render/prepared_splat.h"
#include "server/io/splat_file.h"
#include "server/store/texton_store.h"

#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::store {

class SplatStore {
public:
    static Result<std::unique_ptr<SplatStore>> open(const std::string& data_dir,
                                                    TextonStore& textons);

    bool contains(const std::string& id);
    Result<api::SplatMeta> meta(const std::string& id);
    Result<std::shared_ptr<const render::PreparedSplat>> prepared(const std::string& id);
    // The record made ready: its layers (and height) from the texton store, validated. What
    // creation checks before anything is written.
    Result<std::shared_ptr<const render::PreparedSplat>> prepare(const io::SplatRecord& record);
    // Writes the files (atomically); false when the splat was already there.
    Result<bool> put(const io::SplatRecord& record);
    // Splats whose files were damaged or failed today's rules at load, moved to
    // <data>/splats/quarantine/.
    std::vector<std::string> quarantined() const;

private:
    struct Entry {
        std::string id;
        api::SplatMeta meta;
        std::shared_ptr<const render::PreparedSplat> prepared;
        std::size_t bytes = 0; // its weight image
    };
    // not_found when a layer (or the rules' height) is no longer stored.
    std::optional<Error> layers_stored(const api::SplatMeta& meta);
    SplatStore(std::string dir, TextonStore& textons) : m_dir(std::move(dir)), m_textons(textons) {}
    Result<Entry> load(const std::string& id);
    void quarantine(const std::string& id, const std::string& why);
    std::string m_dir;
    TextonStore& m_textons;
    mutable std::mutex m_mutex;
    std::mutex m_put_mutex;
    std::vector<std::string> m_quarantined;
    std::list<Entry> m_lru; // front = most recent
    std::size_t m_bytes = 0;
    static constexpr std::size_t kCapacity = 16;
    static constexpr std::size_t kBudgetBytes = std::size_t{256} << 20; // weight images kept
};

} // namespace textond::store
