#include "server/store/splat_store.h"

#include "core/material_set.h"
#include "server/io/slow_point.h"
#include "server/store/quarantine.h"

#include <spdlog/spdlog.h>

#include <algorithm>

namespace textond::store {

namespace {
// A splat's files as the shared store holds them (server/io/splat_file.h): the weight images as
// uploaded (2048 x 2048 x 4 channels of 16 bits at most, stored uncompressed at worst, 32 MiB),
// or the float planes of a splat stored before (8 of 2048 x 2048), first; the metadata last.
std::vector<SharedObjects::File> splat_files() {
    constexpr long long kUpload = core::kMaxSplatWeightPixels * 4 * 2 + (8LL << 20);
    return {{".weights.exr", 8 * core::kMaxSplatWeightPixels * 4 + (8LL << 20)},
            {".weights.upload", kUpload},
            {".weights2.upload", kUpload},
            {".json", 1LL << 20}};
}
} // namespace

SplatStore::SplatStore(std::string dir, TextonStore& textons, std::chrono::milliseconds recheck)
    : m_dir(std::move(dir)), m_textons(textons),
      m_shared(textons.shared(), "splat", m_dir, splat_files(), recheck),
      m_quarantined(quarantined_on_disk(m_dir, true)) {}

Result<std::unique_ptr<SplatStore>> SplatStore::open(const std::string& data_dir,
                                                     TextonStore& textons,
                                                     std::chrono::milliseconds recheck) {
    auto dir = open_object_directory(data_dir, "splats");
    if (!dir) return dir.error();
    return std::unique_ptr<SplatStore>(new SplatStore(dir.value(), textons, recheck));
}

bool SplatStore::contains(const std::string& id) {
    return m_shared.contains(id, [&] { forget(id); });
}

void SplatStore::forget(const std::string& id) {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_kept.erase(id);
}

Result<bool> SplatStore::remove(const std::string& id) {
    auto there = m_shared.remove_everywhere(id);
    if (!there) return there.error();
    forget(id);
    if (!there.value()) return make_error(ErrorCode::not_found, "no splat " + id);
    return true;
}

Result<std::shared_ptr<const render::PreparedSplat>>
SplatStore::prepare(const io::SplatRecord& record) {
    std::vector<std::shared_ptr<const render::PreparedTexton>> layers;
    for (const std::string& t : record.meta.textons) {
        auto p = m_textons.prepared(t);
        if (!p) {
            if (p.error().code != ErrorCode::not_found) return p.error();
            return make_error(ErrorCode::not_found, "texton " + t + " of splat " + record.meta.id +
                                                        " is not stored here (deleted, or never "
                                                        "uploaded): upload it again");
        }
        if (!p.value()->texton().maps.empty())
            return make_error(ErrorCode::invalid_argument,
                              "layer " + t +
                                  " is a material set: splat layers are textons of "
                                  "one exemplar (grey or RGB)");
        layers.push_back(p.value());
    }
    std::shared_ptr<const render::PreparedTexton> height;
    if (!record.height.empty()) {
        auto set = m_textons.prepared(record.height);
        if (!set)
            return set.error().code == ErrorCode::not_found
                       ? make_error(ErrorCode::not_found, "the rules' height texton " +
                                                              record.height + " is not stored here")
                       : set.error();
        const core::Texton& t = set.value()->texton();
        if (!t.maps.empty() && !core::find_map(t.maps, "height"))
            return make_error(ErrorCode::invalid_argument,
                              "the rules' height " + record.height +
                                  " is a material set without a height map");
        if (t.order == 0)
            return make_error(ErrorCode::invalid_argument,
                              "the rules' height " + record.height +
                                  " has interpolation order 0, which has no slope (upload it "
                                  "with order 1 or 3)");
        if (!t.maps.empty()) {
            auto view = render::map_view(set.value(), core::kNormalMap); // the set's height
            if (!view) return view.error();
            height = view.value();
        } else if (set.value()->channels() == 1) {
            height = set.value();
        } else {
            return make_error(ErrorCode::invalid_argument,
                              "the rules' height is a grey texton or a material set with a height "
                              "map; " +
                                  record.height + " is a colour texton");
        }
    }
    return render::PreparedSplat::make(std::move(layers), record.weights, std::move(height));
}

std::optional<Error> SplatStore::layers_stored(const api::SplatMeta& meta) {
    std::vector<std::string> ids = meta.textons;
    if (const auto h = meta.weights.find("height"); h != meta.weights.end() && h->is_string())
        ids.push_back(h->get<std::string>());
    for (const std::string& t : ids)
        if (auto found = m_textons.find(t); !found) {
            if (found.error().code != ErrorCode::not_found) return found.error();
            return make_error(ErrorCode::not_found,
                              "texton " + t + " of splat " + meta.id +
                                  " is not stored here (deleted, or never uploaded): upload it "
                                  "again");
        }
    return std::nullopt;
}

std::optional<SplatStore::Entry> SplatStore::kept(const std::string& id) {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_kept.get(id);
}

Result<SplatStore::Entry> SplatStore::load(const std::string& id) {
    std::optional<Entry> kept = this->kept(id);
    if (kept && !m_shared.held(id)) { // its files erased: deleted elsewhere (the shared sweep)
        forget(id);
        kept.reset();
    }
    if ((kept || m_shared.held(id)) &&
        m_shared.deleted_elsewhere(id)) { // deleted on another replica
        m_shared.erase_local(id);
        forget(id);
        return make_error(ErrorCode::not_found, "no splat " + id + " (deleted)");
    }
    if (kept) {
        // A prepared splat holds its layers: one deleted since must not go on rendering here.
        auto gone = layers_stored(kept->meta);
        if (!gone) return *kept;
        forget(id);
        return *gone;
    }
    // Not in memory: one load an id (the requests that come meanwhile wait for its outcome), and
    // a few ids at once (load_limit.h).
    return m_loads.run(id, [&]() -> Result<Entry> {
        if (auto again = this->kept(id)) return *again; // a load that just ended
        return m_limit.run<Entry>("splats", kLoadWait, [&] { return load_files(id); });
    });
}

Result<SplatStore::Entry> SplatStore::load_files(const std::string& id) {
    bool fetched = false;
    if (!m_shared.held(id)) {
        auto got = m_shared.fetch(id);
        if (!got) return got.error();
        fetched = got.value();
    }
    auto record = io::read_splat_files(m_dir, id);
    if (!record && fetched && record.error().code == ErrorCode::io) {
        // What the shared store holds is damaged: refused (500), not fetched or kept again.
        m_shared.reject(id);
        spdlog::error("splats: {} from the shared store refused ({})", id, record.error().message);
        return make_error(ErrorCode::io, "splat " + id + " in the shared store is damaged (" +
                                             record.error().message + "); it is not served");
    }
    if (!record && record.error().code == ErrorCode::io) {
        quarantine(id, record.error().message);
        return make_error(ErrorCode::not_found, "no splat " + id +
                                                    " (its files were damaged or failed "
                                                    "validation, and were quarantined)");
    }
    if (!record) return record.error();
    io::slow_point("load", 1.0); // tests: a load that lasts, its files read (slow_point.h)
    auto prepared = prepare(record.value());
    if (!prepared) return prepared.error(); // a missing layer: kept, for when it comes back
    const core::Image& w = record.value().weights.image.weights;
    Entry e{id, record.value().meta, prepared.value(), w.data.size() * sizeof(float)};
    std::lock_guard<std::mutex> lock(m_mutex);
    // Deleted while it loaded (remove() erases the files, then forgets): not kept, not served.
    if (!m_shared.held(id))
        return make_error(ErrorCode::not_found, "no splat " + id + " (deleted)");
    m_kept.put(e); // in place of one kept meanwhile (a creation's load)
    return e;
}

Result<api::SplatMeta> SplatStore::meta(const std::string& id) {
    auto e = load(id);
    if (!e) return e.error();
    return e.value().meta;
}

Result<std::shared_ptr<const render::PreparedSplat>> SplatStore::prepared(const std::string& id) {
    auto e = load(id);
    if (!e) return e.error();
    return e.value().prepared;
}

void SplatStore::quarantine(const std::string& id, const std::string& why) {
    const std::string dir = quarantine_files(
        m_dir, id, {".json", ".weights.exr", ".weights.upload", ".weights2.upload"});
    spdlog::error("splats: {} refused at load ({}); moved to {}", id, why, dir);
    std::lock_guard<std::mutex> lock(m_mutex);
    m_quarantined.add(id);
}

std::size_t SplatStore::quarantined_count() const {
    std::lock_guard lock(m_mutex);
    return m_quarantined.count();
}

std::vector<std::string> SplatStore::quarantined() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_quarantined.names();
}

Result<bool> SplatStore::put(const io::SplatRecord& record) {
    // One writer at a time: of concurrent identical creations one writes and says so.
    std::lock_guard<std::mutex> lock(m_put_mutex);
    if (contains(record.meta.id)) return false;
    const InFlightIds::Mark creating(m_shared.creations(), record.meta.id);
    auto ok = io::write_splat_files(m_dir, record);
    if (!ok) return ok.error();
    auto shared = m_shared.publish(record.meta.id);
    if (!shared) { // not stored where the other replicas look: not stored at all
        m_shared.erase_local(record.meta.id);
        return shared.error();
    }
    return shared.value(); // false: another replica stored it first
}

} // namespace textond::store
