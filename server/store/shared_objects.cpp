#include "server/store/shared_objects.h"

#include "server/io/atomic_file.h"
#include "server/io/image_io.h"
#include "server/store/read_through.h"

#include <spdlog/spdlog.h>

#include <filesystem>
#include <malloc.h>

namespace textond::store {

Result<std::string> open_object_directory(const std::string& data_dir, const std::string& name) {
    const std::string dir = data_dir + "/" + name;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) return make_error(ErrorCode::io, "cannot create " + dir + ": " + ec.message());
    for (const std::string& file : io::remove_unfinished_writes(dir))
        spdlog::warn("{}: removed an unfinished write {}", name, file);
    return dir;
}

SharedObjects::SharedObjects(RedisStore* shared, std::string kind, std::string dir,
                             std::vector<File> files, std::chrono::milliseconds recheck)
    : m_shared(shared), m_kind(std::move(kind)), m_dir(std::move(dir)), m_files(std::move(files)),
      m_recheck(recheck) {
    if (m_shared) m_sweeper.emplace(m_recheck, [this] { sweep(); });
}

// Each held object's presence, once an interval: one absent from the store is written back
// there; the files of one deleted there are erased (a delete answered by another replica had
// left them on this disk for good, and a flushed Redis got them back as "missing"). What the
// store prepared of it in memory goes at the next request's recheck, which finds no files. The
// sweep keeps off the requests' recheck clock (deleted_elsewhere's: had it taken an interval's
// look, a request within it would have served a deleted splat).
void SharedObjects::sweep() {
    const std::string& main = m_files.back().suffix;
    std::error_code ec;
    for (std::filesystem::directory_iterator it(m_dir, ec), end; !ec && it != end;
         it.increment(ec)) {
        if (m_sweeper->stopping()) return;
        const std::string name = it->path().filename().string();
        if (name.size() != 64 + main.size() || name.compare(64, main.size(), main) != 0) continue;
        const std::string id = name.substr(0, 64);
        if (id.find_first_not_of("0123456789abcdef") != std::string::npos) continue;
        auto presence = m_shared->object_presence(m_kind, id);
        if (!presence) return; // the store down: tried again next round
        if (presence.value() == RedisStore::Presence::deleted) {
            // Not while the id is being created again here: those files are the new object's.
            // Asked again under the creations' lock, which a creation takes before its files: one
            // that marked, stored over the tombstone and unmarked since the look above is seen.
            if (m_creating.unless_marked(id, [&] {
                    auto now = m_shared->object_presence(m_kind, id);
                    if (now && now.value() == RedisStore::Presence::deleted) erase_local(id);
                }))
                spdlog::info("store: {} {} was deleted from the shared store; its files here "
                             "erased",
                             m_kind, id);
            continue;
        }
        if (presence.value() != RedisStore::Presence::unknown) continue;
        if (auto put = publish(id, /*write_back=*/true); put && put.value())
            spdlog::warn("store: {} {} was missing from the shared store; written back", m_kind,
                         id);
    }
}

bool SharedObjects::held(const std::string& id) const {
    std::error_code ec;
    return std::filesystem::is_regular_file(m_dir + "/" + id + m_files.back().suffix, ec);
}

bool SharedObjects::contains(const std::string& id, const std::function<void()>& dropped) {
    if (held(id)) {
        if (!deleted_elsewhere(id, true)) return true;
        erase_local(id);
        dropped();
        return false;
    }
    auto fetched = fetch(id);
    return fetched && fetched.value();
}

Result<bool> SharedObjects::remove_everywhere(const std::string& id) {
    bool there = false;
    if (m_shared) {
        auto r = remove(id);
        if (!r) return r.error();
        there = r.value();
    }
    there = held(id) || there;
    erase_local(id);
    return there;
}

Result<bool> SharedObjects::publish(const std::string& id, bool write_back) {
    if (!m_shared) return true;
    if (write_back && m_creating.contains(id)) return false; // its creation publishes it soon
    RedisStore::Files files;
    std::error_code ec;
    for (const File& f : m_files) {
        const std::string path = m_dir + "/" + id + f.suffix;
        if (!std::filesystem::is_regular_file(path, ec)) continue; // optional (no mask)
        auto bytes = io::read_file(path);
        if (!bytes) return bytes.error();
        files.emplace(f.suffix, std::move(bytes.value()));
    }
    if (!files.count(m_files.back().suffix)) { // erased meanwhile (a delete): nothing whole
        if (write_back) return false;
        return make_error(ErrorCode::not_found,
                          m_kind + " " + id + " was deleted while it was made");
    }
    auto stored = m_shared->put_object(m_kind, id, files, write_back);
    if (stored) {
        std::lock_guard lock(m_mutex);
        m_checked[id] = std::chrono::steady_clock::now();
    }
    return stored;
}

Result<bool> SharedObjects::fetch(const std::string& id) {
    if (!m_shared) return false;
    auto result = m_fetches.run(id, [&] { return fetch_once(id); });
    if (result && result.value()) {
        std::lock_guard lock(m_mutex);
        m_checked[id] = std::chrono::steady_clock::now();
    }
    ::malloc_trim(0); // weights and masks are large transient buffers
    return result;
}

Result<bool> SharedObjects::fetch_once(const std::string& id) {
    std::map<std::string, long long> caps;
    for (const File& f : m_files) caps[f.suffix] = f.cap;
    std::string signature;
    auto got = m_shared->get_object(m_kind, id, caps, &signature);
    if (!got) {
        if (got.error().code != ErrorCode::unavailable)
            spdlog::error("store: {}", got.error().message);
        return got.error();
    }
    if (!got.value()) return false;
    const RedisStore::Files& files = *got.value();
    if (!files.count(m_files.back().suffix))
        return make_error(ErrorCode::io, m_kind + " " + id +
                                             " in the shared store lacks its main file; it is "
                                             "not served");
    // In writing order, the main file last: a crash between leaves no whole-looking object.
    for (const File& f : m_files) {
        const auto it = files.find(f.suffix);
        if (it == files.end()) continue;
        if (auto w = io::write_file_atomic(m_dir + "/" + id + f.suffix, it->second); !w) {
            erase_local(id);
            return read_through_error(m_kind + " " + id, w.error());
        }
    }
    std::lock_guard lock(m_mutex);
    m_fetched_signature[id] = signature;
    return true;
}

void SharedObjects::reject(const std::string& id) {
    erase_local(id);
    if (!m_shared) return;
    std::string signature;
    {
        std::lock_guard lock(m_mutex);
        const auto it = m_fetched_signature.find(id);
        if (it == m_fetched_signature.end()) return;
        signature = it->second;
        m_fetched_signature.erase(it);
    }
    m_shared->refuse_object(m_kind, id, signature);
}

bool SharedObjects::deleted_elsewhere(const std::string& id, bool now_) {
    if (!m_shared) return false;
    {
        std::lock_guard lock(m_mutex);
        const auto now = std::chrono::steady_clock::now();
        auto& checked = m_checked[id];
        if (!now_ && now < checked + m_recheck) return false;
        checked = now; // one request an interval makes the round trip
    }
    auto presence = m_shared->object_presence(m_kind, id);
    if (!presence) return false; // down: serve what we hold
    if (presence.value() == RedisStore::Presence::deleted) {
        spdlog::info("store: {} {} was deleted from the shared store; dropped here", m_kind, id);
        return true;
    }
    if (presence.value() == RedisStore::Presence::unknown) {
        // Held here, absent there (a flushed Redis, or made before the shared store was
        // configured): written back so the other replicas find it.
        if (auto put = publish(id, /*write_back=*/true); put && put.value())
            spdlog::warn("store: {} {} was missing from the shared store; written back", m_kind,
                         id);
    }
    return false;
}

Result<bool> SharedObjects::remove(const std::string& id) {
    if (!m_shared) return false;
    auto r = m_shared->remove_object(m_kind, id);
    if (r) {
        std::lock_guard lock(m_mutex);
        m_checked.erase(id);
    }
    return r;
}

void SharedObjects::erase_local(const std::string& id) const {
    std::error_code ec; // the main file first: what is left never looks whole
    for (auto f = m_files.rbegin(); f != m_files.rend(); ++f)
        std::filesystem::remove(m_dir + "/" + id + f->suffix, ec);
}

} // namespace textond::store
