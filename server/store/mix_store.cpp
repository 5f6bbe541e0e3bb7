#include "server/store/mix_store.h"

#include "server/store/quarantine.h"

#include <spdlog/spdlog.h>

#include <filesystem>

namespace textond::store {

Result<std::unique_ptr<MixStore>> MixStore::open(const std::string& data_dir) {
    const std::string dir = data_dir + "/mixes";
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return make_error(ErrorCode::io, "cannot create " + dir + ": " + ec.message());
    return std::unique_ptr<MixStore>(new MixStore(dir));
}

bool MixStore::contains(const std::string& id) {
    std::error_code ec;
    return std::filesystem::is_regular_file(m_dir + "/" + id + ".exr", ec);
}

Result<MixStore::Entry> MixStore::load(const std::string& id) {
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        for (auto it = m_lru.begin(); it != m_lru.end(); ++it)
            if (it->id == id) {
                m_lru.splice(m_lru.begin(), m_lru, it);
                return *it;
            }
    }
    auto record = io::read_mix_files(m_dir, id);
    if (!record && record.error().code == ErrorCode::io) {
        quarantine(id, record.error().message);
        return make_error(ErrorCode::not_found, "no mix " + id +
                                                    " (its files were damaged or "
                                                    "failed validation, and were quarantined)");
    }
    if (!record) return record.error();
    auto prepared = render::PreparedMix::make(record.value().levels, record.value().field);
    if (!prepared) {
        quarantine(id, prepared.error().message);
        return make_error(ErrorCode::not_found, "no mix " + id +
                                                    " (it failed validation and "
                                                    "was quarantined)");
    }
    Entry e{id, record.value().meta, prepared.value()};
    std::lock_guard<std::mutex> lock(m_mutex);
    m_lru.push_front(e);
    if (m_lru.size() > kCapacity) m_lru.pop_back();
    return e;
}

Result<api::MixMeta> MixStore::meta(const std::string& id) {
    auto e = load(id);
    if (!e) return e.error();
    return e.value().meta;
}

Result<std::shared_ptr<const render::PreparedMix>> MixStore::prepared(const std::string& id) {
    auto e = load(id);
    if (!e) return e.error();
    return e.value().prepared;
}

void MixStore::quarantine(const std::string& id, const std::string& why) {
    const std::string dir = quarantine_files(m_dir, id, {".exr", ".mask.exr"});
    spdlog::error("mixes: {} refused at load ({}); moved to {}", id, why, dir);
    std::lock_guard<std::mutex> lock(m_mutex);
    m_quarantined.push_back(id);
}

std::vector<std::string> MixStore::quarantined() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_quarantined;
}

Result<bool> MixStore::put(const io::MixRecord& record) {
    const std::string& id = record.meta.id;
    if (contains(id)) return false;
    auto ok = io::write_mix_files(m_dir, record);
    if (!ok) return ok.error();
    return true;
}

} // namespace textond::store
