#include "server/store/splat_store.h"

#include "server/store/quarantine.h"

#include <spdlog/spdlog.h>

#include <filesystem>

namespace textond::store {

Result<std::unique_ptr<SplatStore>> SplatStore::open(const std::string& data_dir,
                                                     TextonStore& textons) {
    const std::string dir = data_dir + "/splats";
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return make_error(ErrorCode::io, "cannot create " + dir + ": " + ec.message());
    return std::unique_ptr<SplatStore>(new SplatStore(dir, textons));
}

bool SplatStore::contains(const std::string& id) {
    std::error_code ec;
    return std::filesystem::is_regular_file(m_dir + "/" + id + ".json", ec);
}

Result<std::shared_ptr<const render::PreparedSplat>>
SplatStore::prepare(const io::SplatRecord& record) {
    std::vector<std::shared_ptr<const render::PreparedTexton>> layers;
    for (const std::string& t : record.meta.textons) {
        auto p = m_textons.prepared(t);
        if (!p) {
            if (p.error().code != ErrorCode::not_found) return p.error();
            return make_error(ErrorCode::not_found, "the splat's layer texton " + t +
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
        if (!set.value()->texton().maps.empty()) {
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

Result<SplatStore::Entry> SplatStore::load(const std::string& id) {
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        for (auto it = m_lru.begin(); it != m_lru.end(); ++it)
            if (it->id == id) {
                m_lru.splice(m_lru.begin(), m_lru, it);
                return *it;
            }
    }
    auto record = io::read_splat_files(m_dir, id);
    if (!record && record.error().code == ErrorCode::io) {
        quarantine(id, record.error().message);
        return make_error(ErrorCode::not_found, "no splat " + id +
                                                    " (its files were damaged or failed "
                                                    "validation, and were quarantined)");
    }
    if (!record) return record.error();
    auto prepared = prepare(record.value());
    if (!prepared) return prepared.error(); // a missing layer: kept, for when it comes back
    Entry e{id, record.value().meta, prepared.value()};
    std::lock_guard<std::mutex> lock(m_mutex);
    m_lru.push_front(e);
    if (m_lru.size() > kCapacity) m_lru.pop_back();
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
    const std::string dir = quarantine_files(m_dir, id, {".json", ".weights.exr"});
    spdlog::error("splats: {} refused at load ({}); moved to {}", id, why, dir);
    std::lock_guard<std::mutex> lock(m_mutex);
    m_quarantined.push_back(id);
}

std::vector<std::string> SplatStore::quarantined() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_quarantined;
}

Result<bool> SplatStore::put(const io::SplatRecord& record) {
    if (contains(record.meta.id)) return false;
    auto ok = io::write_splat_files(m_dir, record);
    if (!ok) return ok.error();
    return true;
}

} // namespace textond::store
