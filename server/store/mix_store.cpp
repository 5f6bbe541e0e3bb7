#include "server/store/mix_store.h"

#include "server/io/slow_point.h"
#include "server/store/quarantine.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <optional>

namespace textond::store {

namespace {
// A mix's files as the shared store holds them (server/io/mix_file.h): the mask (a float image of
// at most --max-pixels) first, the levels (64 of 256 x 256 RGB at most) last. With room for
// EXR's headers and incompressible data.
std::vector<SharedObjects::File> mix_files() {
    return {{".mask.exr", (16LL << 20) * 4 + (8LL << 20)},
            {".exr", 64LL * 256 * 256 * 3 * 4 + (8LL << 20)}};
}

// What a prepared mix holds beside its mask: each level's texton and its tables, about four
// copies of the texton's floats.
std::size_t level_bytes(const std::vector<core::Texton>& levels) {
    std::size_t n = 0;
    for (const core::Texton& t : levels) n += t.alpha.data.size() * sizeof(float) * 4;
    return n;
}
} // namespace

MixStore::MixStore(std::string dir, RedisStore* shared, std::chrono::milliseconds recheck)
    : m_dir(std::move(dir)), m_shared(shared, "mix", m_dir, mix_files(), recheck),
      m_quarantined(quarantined_on_disk(m_dir, true)) {}

Result<std::unique_ptr<MixStore>> MixStore::open(const std::string& data_dir, RedisStore* shared,
                                                 std::chrono::milliseconds recheck) {
    auto dir = open_object_directory(data_dir, "mixes");
    if (!dir) return dir.error();
    return std::unique_ptr<MixStore>(new MixStore(dir.value(), shared, recheck));
}

bool MixStore::contains(const std::string& id) {
    return m_shared.contains(id, [&] { forget(id); });
}

Result<io::MixRecord> MixStore::levels(const std::string& id) {
    if (!contains(id)) return make_error(ErrorCode::not_found, "no mix " + id);
    return io::read_mix_files(m_dir, id, true);
}

void MixStore::forget(const std::string& id) {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_kept.erase(id);
}

Result<bool> MixStore::remove(const std::string& id) {
    auto there = m_shared.remove_everywhere(id);
    if (!there) return there.error();
    forget(id);
    if (!there.value()) return make_error(ErrorCode::not_found, "no mix " + id);
    return true;
}

std::optional<MixStore::Entry> MixStore::kept(const std::string& id) {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_kept.get(id);
}

Result<MixStore::Entry> MixStore::load(const std::string& id) {
    std::optional<Entry> kept = this->kept(id);
    if (kept && !m_shared.held(id)) { // its files erased: deleted elsewhere (the shared sweep)
        forget(id);
        kept.reset();
    }
    if (kept || m_shared.held(id)) {
        if (m_shared.deleted_elsewhere(id)) { // deleted on another replica
            m_shared.erase_local(id);
            forget(id);
            return make_error(ErrorCode::not_found, "no mix " + id + " (deleted)");
        }
        if (kept) return *kept;
    }
    // Not in memory: one load an id (the requests that come meanwhile wait for its outcome), and
    // a few ids at once (load_limit.h).
    return m_loads.run(id, [&]() -> Result<Entry> {
        if (auto again = this->kept(id)) return *again; // a load that just ended
        return m_limit.run<Entry>("mixes", kLoadWait, [&] { return load_files(id); });
    });
}

Result<MixStore::Entry> MixStore::load_files(const std::string& id) {
    bool fetched = false;
    if (!m_shared.held(id)) {
        auto got = m_shared.fetch(id);
        if (!got) return got.error();
        fetched = got.value();
    }
    auto record = io::read_mix_files(m_dir, id);
    if (!record && fetched && record.error().code == ErrorCode::io) {
        // What the shared store holds is damaged: refused (500), not fetched or kept again.
        m_shared.reject(id);
        spdlog::error("mixes: {} from the shared store refused ({})", id, record.error().message);
        return make_error(ErrorCode::io, "mix " + id + " in the shared store is damaged (" +
                                             record.error().message + "); it is not served");
    }
    if (!record && record.error().code == ErrorCode::io) {
        quarantine(id, record.error().message);
        return make_error(ErrorCode::not_found, "no mix " + id +
                                                    " (its files were damaged or "
                                                    "failed validation, and were quarantined)");
    }
    if (!record) return record.error();
    io::slow_point("load", 1.0); // tests: a load that lasts, its files read (slow_point.h)
    auto prepared = render::PreparedMix::make(record.value().levels, record.value().field);
    if (!prepared && fetched) {
        m_shared.reject(id);
        return make_error(ErrorCode::io, "mix " + id + " in the shared store fails validation (" +
                                             prepared.error().message + "); it is not served");
    }
    if (!prepared) {
        quarantine(id, prepared.error().message);
        return make_error(ErrorCode::not_found, "no mix " + id +
                                                    " (it failed validation and "
                                                    "was quarantined)");
    }
    const core::MixField& f = record.value().field;
    Entry e{id, record.value().meta, prepared.value(),
            f.mask.data.size() * sizeof(float) + level_bytes(record.value().levels)};
    std::lock_guard<std::mutex> lock(m_mutex);
    // Deleted while it loaded (remove() erases the files, then forgets): not kept, not served.
    if (!m_shared.held(id)) return make_error(ErrorCode::not_found, "no mix " + id + " (deleted)");
    m_kept.put(e); // in place of one kept meanwhile (a creation's load)
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
    m_quarantined.add(id);
}

std::size_t MixStore::quarantined_count() const {
    std::lock_guard lock(m_mutex);
    return m_quarantined.count();
}

std::vector<std::string> MixStore::quarantined() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_quarantined.names();
}

Result<bool> MixStore::put(const io::MixRecord& record) {
    const std::string& id = record.meta.id;
    if (contains(id)) return false;
    const InFlightIds::Mark creating(m_shared.creations(), id);
    auto ok = io::write_mix_files(m_dir, record);
    if (!ok) return ok.error();
    auto shared = m_shared.publish(id);
    if (!shared) { // not stored where the other replicas look: not stored at all
        m_shared.erase_local(id);
        return shared.error();
    }
    return shared.value(); // false: another replica stored it first
}

} // namespace textond::store
