#include "server/http/texton_store.h"

#include "api/requests.h"
#include "server/http/http_support.h"
#include "server/io/image_io.h"

#include <spdlog/spdlog.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <unistd.h>

namespace textond::http {

namespace fs = std::filesystem;

namespace {

constexpr const char* kExtension = ".exr";

// A rename is durable only once its directory entry is.
void fsync_directory(const std::string& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
}

} // namespace

TextonStore::TextonStore(const std::string& dir, std::size_t prepared_cache,
                         std::unique_ptr<store::RedisStore> shared,
                         std::chrono::milliseconds recheck)
    : m_dir((fs::path(dir) / "textons").string()),
      m_exemplars((fs::path(dir) / "exemplars").string()),
      m_provenance((fs::path(dir) / "provenance").string()),
      m_quarantine((fs::path(dir) / "quarantine").string()),
      m_prepared_capacity(prepared_cache == 0 ? 1 : prepared_cache), m_shared(std::move(shared)),
      m_recheck(recheck) {}

std::string TextonStore::path_of(const std::string& id) const {
    if (!api::is_texton_id(id)) throw std::logic_error("TextonStore: unchecked id");
    return (fs::path(m_dir) / (id + kExtension)).string();
}

std::string TextonStore::exemplar_path_of(const std::string& id) const {
    if (!api::is_texton_id(id)) throw std::logic_error("TextonStore: unchecked id");
    return (fs::path(m_exemplars) / (id + ".png")).string();
}

std::string TextonStore::provenance_path_of(const std::string& id) const {
    if (!api::is_texton_id(id)) throw std::logic_error("TextonStore: unchecked id");
    return (fs::path(m_provenance) / (id + ".json")).string();
}

api::TextonMeta TextonStore::with_provenance(const std::string& id, api::TextonMeta meta) const {
    auto text = io::read_file(provenance_path_of(id));
    if (!text) return meta; // none kept (fetched from a store without it, or lost): unknown
    try {
        api::read_provenance(nlohmann::json::parse(text.value()), meta);
    } catch (const std::exception& e) {
        spdlog::warn("store: unreadable provenance of texton {} ({}); ignored", id, e.what());
    }
    return meta;
}

Result<std::unique_ptr<TextonStore>> TextonStore::open(const std::string& data_dir,
                                                       std::size_t prepared_cache,
                                                       std::unique_ptr<store::RedisStore> shared,
                                                       std::chrono::milliseconds recheck) {
    std::unique_ptr<TextonStore> s(
        new TextonStore(data_dir, prepared_cache, std::move(shared), recheck));
    std::error_code ec;
    for (const std::string& d : {s->m_dir, s->m_exemplars, s->m_provenance, s->m_quarantine}) {
        fs::create_directories(d, ec);
        if (ec) return make_error(ErrorCode::io, "cannot create " + d + ": " + ec.message());
    }
    std::lock_guard lock(s->m_mutex);
    for (const auto& entry : fs::directory_iterator(s->m_dir, ec)) {
        const std::string name = entry.path().filename().string();
        // Temporary files of writes a crash interrupted: never complete, never referenced.
        if (!name.empty() && name[0] == '.') {
            fs::remove(entry.path(), ec);
            spdlog::warn("store: removed an unfinished write {}", name);
            continue;
        }
        const std::string stem = entry.path().stem().string();
        if (entry.path().extension() != kExtension || !api::is_texton_id(stem)) {
            spdlog::warn("store: ignoring {} (not a texton file name)", name);
            continue;
        }
        auto r = io::read_texton_file(entry.path().string());
        if (!r) {
            s->quarantine_locked(stem, r.error().message);
            continue;
        }
        if (r.value().meta.id != stem) {
            s->quarantine_locked(stem, "its metadata names another id");
            continue;
        }
        s->m_sizes[stem] = fs::file_size(entry.path(), ec);
        s->m_index[stem] = s->with_provenance(stem, std::move(r.value().meta));
    }
    if (ec) return make_error(ErrorCode::io, "cannot list " + s->m_dir + ": " + ec.message());
    // Exemplars and provenance of textons that were never completed (a crash between the
    // writes) or whose texton was quarantined, and unfinished writes.
    for (const std::string& dir : {s->m_exemplars, s->m_provenance})
        for (const auto& entry : fs::directory_iterator(dir, ec)) {
            const std::string name = entry.path().filename().string();
            const std::string stem = entry.path().stem().string();
            if ((!name.empty() && name[0] == '.') || !s->m_index.count(stem)) fs::remove(entry, ec);
        }
    spdlog::info("store: {} textons in {}{}{}", s->m_index.size(), s->m_dir,
                 s->m_shared ? " (a cache of " + s->m_shared->describe() + ")" : "",
                 s->m_quarantined.empty()
                     ? ""
                     : ", " + std::to_string(s->m_quarantined.size()) + " quarantined");
    return s;
}

void TextonStore::quarantine_locked(const std::string& id, const std::string& why) {
    const fs::path from = path_of(id);
    const std::string name = id + kExtension + "." +
                             std::to_string(std::chrono::system_clock::now().time_since_epoch() /
                                            std::chrono::milliseconds(1));
    std::error_code ec;
    fs::rename(from, fs::path(m_quarantine) / name, ec);
    if (ec) fs::remove(from, ec); // never leave it where it could be served
    fs::remove(exemplar_path_of(id), ec);
    fs::remove(provenance_path_of(id), ec);
    drop_local_locked(id);
    m_quarantined.push_back(name);
    spdlog::error("store: texton {} is damaged ({}); moved to {}/{}", id, why, m_quarantine, name);
}

void TextonStore::drop_local_locked(const std::string& id) {
    m_index.erase(id);
    m_sizes.erase(id);
    m_checked.erase(id);
    m_prepared.remove_if([&](const auto& p) { return p.first == id; });
}

Result<io::TextonRecord> TextonStore::load_verified(const std::string& id) {
    if (!contains(id))
        if (auto found = find(id); !found) return found.error();
    auto r = io::read_texton_file(path_of(id));
    if (!r || r.value().meta.id != id) {
        std::lock_guard lock(m_mutex);
        if (m_index.count(id))
            quarantine_locked(id, r ? "its metadata names another id" : r.error().message);
        return make_error(ErrorCode::not_found,
                          "texton " + id + " was damaged on disk and has been quarantined");
    }
    return r;
}

Result<api::TextonMeta> TextonStore::find(const std::string& id) {
    api::TextonMeta local;
    {
        std::lock_guard lock(m_mutex);
        auto it = m_index.find(id);
        if (it == m_index.end()) {
            if (!m_shared) return make_error(ErrorCode::not_found, "no texton " + id);
        } else {
            const auto now = std::chrono::steady_clock::now();
            if (!m_shared || now < m_checked[id] + m_recheck) return it->second;
            m_checked[id] = now; // one request per interval makes the round trip
            local = it->second;
        }
    }
    if (local.id.empty()) return fetch_shared(id);
    return recheck(id, std::move(local));
}

Result<api::TextonMeta> TextonStore::recheck(const std::string& id, api::TextonMeta local) {
    auto presence = m_shared->presence(id);
    if (!presence) return local; // the shared store is down: serve what we hold
    switch (presence.value()) {
    case store::RedisStore::Presence::present:
        return local;
    case store::RedisStore::Presence::deleted: {
        std::lock_guard lock(m_mutex);
        std::error_code ec;
        fs::remove(path_of(id), ec);
        fs::remove(exemplar_path_of(id), ec);
        fs::remove(provenance_path_of(id), ec);
        drop_local_locked(id);
        spdlog::info("store: texton {} was deleted from the shared store; dropped here", id);
        return make_error(ErrorCode::not_found, "no texton " + id + " (deleted)");
    }
    case store::RedisStore::Presence::unknown:
        break;
    }
    // Held here but absent there (a flushed Redis, or stored before the shared store was
    // configured): write it back so the other replicas find it.
    auto file = io::read_file(path_of(id));
    auto exemplar = io::read_file(exemplar_path_of(id));
    if (file) {
        const nlohmann::json meta = local;
        auto put = m_shared->put(id, file.value(), meta.dump(), exemplar ? exemplar.value() : "");
        if (put && put.value())
            spdlog::warn("store: texton {} was missing from the shared store; written back", id);
    }
    return local;
}

Result<api::TextonMeta> TextonStore::fetch_shared(const std::string& id) {
    auto got = m_shared->get(id);
    if (!got) {
        if (got.error().code != ErrorCode::unavailable)
            spdlog::error("store: {}", got.error().message);
        return got.error();
    }
    if (!got.value()) return make_error(ErrorCode::not_found, "no texton " + id);
    // The analysing replica's provenance travels in the shared store's metadata.
    nlohmann::json provenance = nlohmann::json::object();
    try {
        api::TextonMeta theirs;
        api::read_provenance(nlohmann::json::parse(got.value()->meta_json), theirs);
        provenance = api::provenance_json(theirs);
    } catch (const std::exception&) {
        // Absent or unreadable: the texton is served without it.
    }
    auto w = write_local(id, got.value()->file, &got.value()->exemplar_png, provenance);
    if (!w) return w.error();
    std::lock_guard lock(m_mutex);
    auto it = m_index.find(id);
    if (it == m_index.end()) return make_error(ErrorCode::not_found, "no texton " + id);
    return it->second;
}

// Writes a texton file (and its exemplar) here, verifies it like every load, then indexes it.
Result<bool> TextonStore::write_local(const std::string& id, const std::string& file,
                                      const std::string* exemplar_png,
                                      const nlohmann::json& provenance) {
    if (exemplar_png && !exemplar_png->empty()) {
        auto w = io::write_file_atomic(exemplar_path_of(id), *exemplar_png);
        if (!w) return w.error();
    }
    // This copy's provenance, or none: an older one must not outlive the copy it described.
    if (!provenance.empty()) {
        auto w = io::write_file_atomic(provenance_path_of(id), provenance.dump(2) + "\n");
        if (!w) return w.error();
        fsync_directory(m_provenance);
    } else {
        std::error_code ec;
        fs::remove(provenance_path_of(id), ec);
    }
    const std::string path = path_of(id);
    std::error_code ec;
    auto w = io::write_file_atomic(path, file);
    if (!w) {
        fs::remove(exemplar_path_of(id), ec);
        fs::remove(provenance_path_of(id), ec);
        return w.error();
    }
    fsync_directory(m_dir);
    auto r = io::read_texton_file(path);
    if (!r || r.value().meta.id != id) {
        fs::remove(path, ec);
        fs::remove(exemplar_path_of(id), ec);
        fs::remove(provenance_path_of(id), ec);
        spdlog::error("store: texton {} fails verification: {}", id,
                      r ? "its metadata names another id" : r.error().message);
        return make_error(ErrorCode::io, "texton " + id + " fails verification; it is not served");
    }
    api::TextonMeta meta = std::move(r.value().meta);
    api::read_provenance(provenance, meta);
    std::lock_guard lock(m_mutex);
    m_sizes[id] = fs::file_size(path, ec);
    m_index[id] = std::move(meta);
    m_checked[id] = std::chrono::steady_clock::now();
    return true;
}

bool TextonStore::contains(const std::string& id) const {
    std::lock_guard lock(m_mutex);
    return m_index.count(id) != 0;
}

Result<std::shared_ptr<const render::PreparedTexton>> TextonStore::prepared(const std::string& id) {
    {
        std::lock_guard lock(m_mutex);
        for (auto it = m_prepared.begin(); it != m_prepared.end(); ++it)
            if (it->first == id) {
                m_prepared.splice(m_prepared.begin(), m_prepared, it);
                return m_prepared.front().second;
            }
    }
    auto r = load_verified(id);
    if (!r) return r.error();
    auto p = render::PreparedTexton::make(std::move(r.value().texton));
    if (!p) return p.error();
    std::lock_guard lock(m_mutex);
    if (!m_index.count(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    for (auto it = m_prepared.begin(); it != m_prepared.end(); ++it)
        if (it->first == id) return it->second; // another thread won the race
    m_prepared.emplace_front(id, p.value());
    while (m_prepared.size() > m_prepared_capacity) m_prepared.pop_back();
    return p.value();
}

Result<io::TextonRecord> TextonStore::record(const std::string& id) {
    return load_verified(id);
}

Result<std::string> TextonStore::file_bytes(const std::string& id) {
    auto r = load_verified(id);
    if (!r) return r.error();
    return io::read_file(path_of(id));
}

Result<bool> TextonStore::put(io::TextonRecord record, const core::Image* exemplar) {
    const std::string id = record.meta.id;
    // Held here; a copy only the shared store holds is found by its write-if-absent below.
    if (contains(id)) return false;
    record.meta.created = rfc3339_now();
    std::string png;
    if (exemplar) {
        auto p = io::encode_image_memory(*exemplar, io::Encoding::png8, {}, 6);
        if (!p) return p.error();
        png = std::move(p.value());
    }
    auto file = io::texton_file_bytes(record);
    if (!file) return file.error();
    if (m_shared) {
        const nlohmann::json meta = record.meta;
        auto stored = m_shared->put(id, file.value(), meta.dump(), png);
        if (!stored) return stored.error();
        if (!stored.value()) { // another replica stored it first: adopt that one
            auto adopted = fetch_shared(id);
            if (!adopted) return adopted.error();
            return false;
        }
    }
    auto w = write_local(id, file.value(), &png, api::provenance_json(record.meta));
    if (!w) return w.error();
    return true;
}

Result<bool> TextonStore::remove(const std::string& id) {
    if (m_shared) {
        auto r = m_shared->remove(id);
        if (!r) return r.error();
        if (!r.value() && !contains(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    }
    std::lock_guard lock(m_mutex);
    if (!m_index.count(id)) {
        if (m_shared) return true; // deleted there; never fetched here
        return make_error(ErrorCode::not_found, "no texton " + id);
    }
    std::error_code ec;
    fs::remove(path_of(id), ec);
    if (ec) return make_error(ErrorCode::io, "cannot delete texton " + id + ": " + ec.message());
    fs::remove(exemplar_path_of(id), ec);
    fs::remove(provenance_path_of(id), ec);
    fsync_directory(m_dir);
    drop_local_locked(id);
    return true;
}

Result<std::string> TextonStore::exemplar_png(const std::string& id) {
    if (auto found = find(id); !found) return found.error();
    auto png = io::read_file(exemplar_path_of(id));
    if (!png && png.error().code == ErrorCode::not_found)
        return make_error(ErrorCode::not_found, "texton " + id +
                                                    " was stored without its exemplar (before "
                                                    "exemplars were kept)");
    return png;
}

Result<std::vector<api::TextonMeta>> TextonStore::list(const std::string& after, int limit) {
    std::vector<api::TextonMeta> out;
    if (m_shared) {
        auto metas = m_shared->list_meta(after, limit);
        if (!metas) return metas.error();
        for (const auto& text : metas.value()) try {
                out.push_back(nlohmann::json::parse(text).get<api::TextonMeta>());
            } catch (const std::exception& e) {
                spdlog::error("store: unreadable metadata in the shared store: {}", e.what());
            }
        return out;
    }
    std::lock_guard lock(m_mutex);
    for (auto it = after.empty() ? m_index.begin() : m_index.upper_bound(after);
         it != m_index.end() && static_cast<int>(out.size()) < limit; ++it)
        out.push_back(it->second);
    return out;
}

Result<std::uint64_t> TextonStore::total() {
    if (m_shared) return m_shared->count();
    return static_cast<std::uint64_t>(count());
}

std::size_t TextonStore::count() const {
    std::lock_guard lock(m_mutex);
    return m_index.size();
}

std::uint64_t TextonStore::bytes() const {
    std::lock_guard lock(m_mutex);
    std::uint64_t total = 0;
    for (const auto& [id, n] : m_sizes) total += n;
    return total;
}

std::vector<std::string> TextonStore::quarantined() const {
    std::lock_guard lock(m_mutex);
    return m_quarantined;
}

bool TextonStore::writable() const {
    const std::string probe = (fs::path(m_dir) / ".readyz-probe").string();
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) return false;
    const bool ok = ::write(fd, "ok", 2) == 2;
    ::close(fd);
    ::unlink(probe.c_str());
    return ok;
}

} // namespace textond::http
