#include "server/http/mix_store.h"

#include <filesystem>

namespace textond::http {

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
    if (!record) return record.error();
    auto prepared = render::PreparedMix::make(record.value().levels, record.value().field);
    if (!prepared) return prepared.error();
    Entry e{id, record.value().meta, prepared.value()};
    std::lock_guard<std::mutex> lock(m_mutex);
    m_lru.push_front(e);
    if (m_lru.size() > kCapacity) m_lru.pop_back();
    return e;
}

Result<nlohmann::json> MixStore::meta(const std::string& id) {
    auto e = load(id);
    if (!e) return e.error();
    return e.value().meta;
}

Result<std::shared_ptr<const render::PreparedMix>> MixStore::prepared(const std::string& id) {
    auto e = load(id);
    if (!e) return e.error();
    return e.value().prepared;
}

Result<bool> MixStore::put(const io::MixRecord& record) {
    const std::string id = record.meta.at("id");
    if (contains(id)) return false;
    auto ok = io::write_mix_files(m_dir, record);
    if (!ok) return ok.error();
    return true;
}

} // namespace textond::http
