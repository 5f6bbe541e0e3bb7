#include "server/store/texton_directory.h"

#include "api/requests.h"
#include "server/io/crash_point.h"
#include "server/io/image_io.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <unistd.h>

namespace textond::store {

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

// The one place an id becomes a path: it was checked, or nothing is joined.
std::string file_of(const std::string& dir, const std::string& id, const char* extension) {
    if (!api::is_texton_id(id)) throw std::logic_error("TextonDirectory: unchecked id");
    return (fs::path(dir) / (id + extension)).string();
}

// The file's metadata with this copy's provenance added when there is one.
api::TextonMeta with_provenance(const std::string& path, api::TextonMeta meta) {
    auto text = io::read_file(path);
    if (!text) return meta; // none kept (fetched from a store without it, or lost): unknown
    try {
        api::read_provenance(nlohmann::json::parse(text.value()), meta);
    } catch (const std::exception& e) {
        spdlog::warn("store: unreadable provenance of texton {} ({}); ignored", meta.id, e.what());
    }
    return meta;
}

bool unfinished(const std::string& name) {
    return !name.empty() && name[0] == '.';
}

} // namespace

TextonDirectory::TextonDirectory(const std::string& data_dir)
    : m_dir((fs::path(data_dir) / "textons").string()),
      m_exemplars((fs::path(data_dir) / "exemplars").string()),
      m_provenance((fs::path(data_dir) / "provenance").string()),
      m_quarantine((fs::path(data_dir) / "quarantine").string()) {}

Result<std::unique_ptr<TextonDirectory>> TextonDirectory::open(const std::string& data_dir) {
    std::unique_ptr<TextonDirectory> d(new TextonDirectory(data_dir));
    std::error_code ec;
    for (const std::string& dir : {d->m_dir, d->m_exemplars, d->m_provenance, d->m_quarantine}) {
        fs::create_directories(dir, ec);
        if (ec) return make_error(ErrorCode::io, "cannot create " + dir + ": " + ec.message());
    }
    std::lock_guard lock(d->m_mutex);
    for (const auto& entry : fs::directory_iterator(d->m_dir, ec)) {
        const std::string name = entry.path().filename().string();
        if (unfinished(name)) { // a write a crash interrupted: never complete, never referenced
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
        if (!r || r.value().meta.id != stem) {
            d->quarantine_locked(stem, r ? "its metadata names another id" : r.error().message);
            continue;
        }
        d->m_sizes[stem] = fs::file_size(entry.path(), ec);
        d->m_index[stem] =
            with_provenance(file_of(d->m_provenance, stem, ".json"), std::move(r.value().meta));
    }
    if (ec) return make_error(ErrorCode::io, "cannot list " + d->m_dir + ": " + ec.message());
    // Exemplars and provenance of textons that were never completed (a crash between the
    // writes) or whose texton was quarantined, and unfinished writes.
    for (const std::string& dir : {d->m_exemplars, d->m_provenance})
        for (const auto& entry : fs::directory_iterator(dir, ec))
            if (unfinished(entry.path().filename().string()) ||
                !d->m_index.count(entry.path().stem().string()))
                fs::remove(entry, ec);
    return d;
}

void TextonDirectory::quarantine_locked(const std::string& id, const std::string& why) {
    const fs::path from = file_of(m_dir, id, kExtension);
    const std::string name = id + kExtension + "." +
                             std::to_string(std::chrono::system_clock::now().time_since_epoch() /
                                            std::chrono::milliseconds(1));
    std::error_code ec;
    fs::rename(from, fs::path(m_quarantine) / name, ec);
    if (ec) fs::remove(from, ec); // never leave it where it could be served
    fs::remove(file_of(m_exemplars, id, ".png"), ec);
    fs::remove(file_of(m_provenance, id, ".json"), ec);
    m_index.erase(id);
    m_sizes.erase(id);
    m_quarantined.push_back(name);
    spdlog::error("store: texton {} is damaged ({}); moved to {}/{}", id, why, m_quarantine, name);
}

std::optional<api::TextonMeta> TextonDirectory::meta(const std::string& id) const {
    std::lock_guard lock(m_mutex);
    auto it = m_index.find(id);
    if (it == m_index.end()) return std::nullopt;
    return it->second;
}

bool TextonDirectory::contains(const std::string& id) const {
    std::lock_guard lock(m_mutex);
    return m_index.count(id) != 0;
}

Result<io::TextonRecord> TextonDirectory::load(const std::string& id) {
    if (!contains(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    auto r = io::read_texton_file(file_of(m_dir, id, kExtension));
    if (!r || r.value().meta.id != id) {
        std::lock_guard lock(m_mutex);
        if (m_index.count(id))
            quarantine_locked(id, r ? "its metadata names another id" : r.error().message);
        return make_error(ErrorCode::not_found,
                          "texton " + id + " was damaged on disk and has been quarantined");
    }
    return r;
}

Result<std::string> TextonDirectory::file(const std::string& id) const {
    return io::read_file(file_of(m_dir, id, kExtension));
}

Result<std::string> TextonDirectory::exemplar(const std::string& id) const {
    return io::read_file(file_of(m_exemplars, id, ".png"));
}

Result<bool> TextonDirectory::write(const std::string& id, const std::string& file,
                                    const std::string* exemplar_png,
                                    const nlohmann::json& provenance) {
    const std::string path = file_of(m_dir, id, kExtension);
    const std::string exemplar = file_of(m_exemplars, id, ".png");
    const std::string told = file_of(m_provenance, id, ".json");
    std::error_code ec;
    auto undo = [&] {
        fs::remove(exemplar, ec);
        fs::remove(told, ec);
    };
    if (exemplar_png && !exemplar_png->empty())
        if (auto w = io::write_file_atomic(exemplar, *exemplar_png); !w) return w.error();
    // This copy's provenance, or none: an older one must not outlive the copy it described.
    if (!provenance.empty()) {
        if (auto w = io::write_file_atomic(told, provenance.dump(2) + "\n"); !w) return w.error();
        fsync_directory(m_provenance);
    } else {
        fs::remove(told, ec);
    }
    if (auto w = io::write_file_atomic(path, file); !w) {
        undo();
        return w.error();
    }
    fsync_directory(m_dir);
    io::crash_point("texton-synced");
    auto r = io::read_texton_file(path);
    if (!r || r.value().meta.id != id) {
        fs::remove(path, ec);
        undo();
        spdlog::error("store: texton {} fails verification: {}", id,
                      r ? "its metadata names another id" : r.error().message);
        return make_error(ErrorCode::io, "texton " + id + " fails verification; it is not served");
    }
    api::TextonMeta meta = std::move(r.value().meta);
    api::read_provenance(provenance, meta);
    std::lock_guard lock(m_mutex);
    m_sizes[id] = fs::file_size(path, ec);
    m_index[id] = std::move(meta);
    return true;
}

Result<bool> TextonDirectory::erase(const std::string& id, bool regardless) {
    {
        std::lock_guard lock(m_mutex);
        if (!m_index.count(id)) return false;
        std::error_code ec;
        fs::remove(file_of(m_dir, id, kExtension), ec);
        if (ec && !regardless)
            return make_error(ErrorCode::io, "cannot delete texton " + id + ": " + ec.message());
        fs::remove(file_of(m_exemplars, id, ".png"), ec);
        fs::remove(file_of(m_provenance, id, ".json"), ec);
        m_index.erase(id);
        m_sizes.erase(id);
    }
    // Outside the lock: every lookup waited on this disk flush before.
    fsync_directory(m_dir);
    return true;
}

std::vector<api::TextonMeta> TextonDirectory::list(const std::string& after, int limit) const {
    std::vector<api::TextonMeta> out;
    std::lock_guard lock(m_mutex);
    for (auto it = after.empty() ? m_index.begin() : m_index.upper_bound(after);
         it != m_index.end() && static_cast<int>(out.size()) < limit; ++it)
        out.push_back(it->second);
    return out;
}

std::size_t TextonDirectory::count() const {
    std::lock_guard lock(m_mutex);
    return m_index.size();
}

std::uint64_t TextonDirectory::bytes() const {
    std::lock_guard lock(m_mutex);
    std::uint64_t total = 0;
    for (const auto& [id, n] : m_sizes) total += n;
    return total;
}

std::vector<std::string> TextonDirectory::quarantined() const {
    std::lock_guard lock(m_mutex);
    return m_quarantined;
}

bool TextonDirectory::writable() const {
    const std::string probe = (fs::path(m_dir) / ".readyz-probe").string();
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) return false;
    const bool ok = ::write(fd, "ok", 2) == 2;
    ::close(fd);
    ::unlink(probe.c_str());
    return ok;
}

} // namespace textond::store
