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

TextonStore::TextonStore(std::string dir, std::size_t prepared_cache)
    : m_dir((fs::path(dir) / "textons").string()),
      m_exemplars((fs::path(dir) / "exemplars").string()),
      m_quarantine((fs::path(dir) / "quarantine").string()),
      m_prepared_capacity(prepared_cache == 0 ? 1 : prepared_cache) {}

std::string TextonStore::path_of(const std::string& id) const {
    if (!api::is_texton_id(id)) throw std::logic_error("TextonStore: unchecked id");
    return (fs::path(m_dir) / (id + kExtension)).string();
}

std::string TextonStore::exemplar_path_of(const std::string& id) const {
    if (!api::is_texton_id(id)) throw std::logic_error("TextonStore: unchecked id");
    return (fs::path(m_exemplars) / (id + ".png")).string();
}

Result<std::unique_ptr<TextonStore>> TextonStore::open(const std::string& data_dir,
                                                       std::size_t prepared_cache) {
    std::unique_ptr<TextonStore> s(new TextonStore(data_dir, prepared_cache));
    std::error_code ec;
    for (const std::string& d : {s->m_dir, s->m_exemplars, s->m_quarantine}) {
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
        s->m_index[stem] = std::move(r.value().meta);
    }
    if (ec) return make_error(ErrorCode::io, "cannot list " + s->m_dir + ": " + ec.message());
    // Exemplars of textons that were never completed (a crash between the two writes) or whose
    // texton was quarantined, and unfinished writes.
    for (const auto& entry : fs::directory_iterator(s->m_exemplars, ec)) {
        const std::string name = entry.path().filename().string();
        const std::string stem = entry.path().stem().string();
        if ((!name.empty() && name[0] == '.') || !s->m_index.count(stem)) fs::remove(entry, ec);
    }
    spdlog::info("store: {} textons in {}{}", s->m_index.size(), s->m_dir,
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
    m_index.erase(id);
    m_sizes.erase(id);
    m_prepared.remove_if([&](const auto& p) { return p.first == id; });
    m_quarantined.push_back(name);
    spdlog::error("store: texton {} is damaged ({}); moved to {}/{}", id, why, m_quarantine, name);
}

Result<io::TextonRecord> TextonStore::load_verified(const std::string& id) {
    if (!contains(id)) return make_error(ErrorCode::not_found, "no texton " + id);
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

std::optional<api::TextonMeta> TextonStore::meta(const std::string& id) const {
    std::lock_guard lock(m_mutex);
    auto it = m_index.find(id);
    if (it == m_index.end()) return std::nullopt;
    return it->second;
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
    if (contains(id)) return false;
    record.meta.created = rfc3339_now();
    if (exemplar) {
        auto png = io::encode_image_memory(*exemplar, io::Encoding::png8, {}, 6);
        if (!png) return png.error();
        auto w = io::write_file_atomic(exemplar_path_of(id), png.value());
        if (!w) return w.error();
    }
    const std::string path = path_of(id);
    auto w = io::write_texton_file(path, record);
    if (!w) {
        std::error_code ec;
        fs::remove(exemplar_path_of(id), ec);
        return w.error();
    }
    fsync_directory(m_dir);
    std::error_code ec;
    std::lock_guard lock(m_mutex);
    m_sizes[id] = fs::file_size(path, ec);
    m_index[id] = record.meta;
    return true;
}

Result<bool> TextonStore::remove(const std::string& id) {
    std::lock_guard lock(m_mutex);
    if (!m_index.count(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    std::error_code ec;
    fs::remove(path_of(id), ec);
    if (ec) return make_error(ErrorCode::io, "cannot delete texton " + id + ": " + ec.message());
    fs::remove(exemplar_path_of(id), ec);
    fsync_directory(m_dir);
    m_index.erase(id);
    m_sizes.erase(id);
    m_prepared.remove_if([&](const auto& p) { return p.first == id; });
    return true;
}

Result<std::string> TextonStore::exemplar_png(const std::string& id) const {
    if (!contains(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    auto png = io::read_file(exemplar_path_of(id));
    if (!png && png.error().code == ErrorCode::not_found)
        return make_error(ErrorCode::not_found, "texton " + id +
                                                    " was stored without its exemplar (before "
                                                    "exemplars were kept)");
    return png;
}

std::vector<api::TextonMeta> TextonStore::list(const std::string& after, int limit) const {
    std::vector<api::TextonMeta> out;
    std::lock_guard lock(m_mutex);
    for (auto it = after.empty() ? m_index.begin() : m_index.upper_bound(after);
         it != m_index.end() && static_cast<int>(out.size()) < limit; ++it)
        out.push_back(it->second);
    return out;
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
