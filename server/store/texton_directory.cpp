#include "server/store/texton_directory.h"

#include "api/requests.h"
#include "server/io/crash_point.h"
#include "server/io/image_io.h"
#include "server/store/quarantine.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <sys/statvfs.h>
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

TextonDirectory::TextonDirectory(const std::string& data_dir, std::size_t meta_cache)
    : m_dir((fs::path(data_dir) / "textons").string()),
      m_exemplars((fs::path(data_dir) / "exemplars").string()),
      m_provenance((fs::path(data_dir) / "provenance").string()),
      m_quarantine((fs::path(data_dir) / "quarantine").string()),
      m_meta_capacity(meta_cache == 0 ? 1 : meta_cache) {}

Result<std::unique_ptr<TextonDirectory>> TextonDirectory::open(const std::string& data_dir,
                                                               std::size_t meta_cache) {
    std::unique_ptr<TextonDirectory> d(new TextonDirectory(data_dir, meta_cache));
    std::error_code ec;
    for (const std::string& dir : {d->m_dir, d->m_exemplars, d->m_provenance, d->m_quarantine}) {
        fs::create_directories(dir, ec);
        if (ec) return make_error(ErrorCode::io, "cannot create " + dir + ": " + ec.message());
    }
    std::error_code list_ec;
    fs::directory_iterator probe(d->m_dir, list_ec);
    if (list_ec)
        return make_error(ErrorCode::io, "cannot list " + d->m_dir + ": " + list_ec.message());
    d->m_quarantined = quarantined_on_disk(data_dir, false);
    d->m_scanner = std::thread([p = d.get()] { p->scan(); });
    return d;
}

TextonDirectory::~TextonDirectory() {
    {
        std::lock_guard lock(m_mutex);
        m_stopping = true;
        m_indexed_cv.notify_all();
    }
    if (m_scanner.joinable()) m_scanner.join();
}

bool TextonDirectory::index_locked(const std::string& id) {
    if (m_files.count(id)) return true;
    // Under the lock: an erase (which removes the file under it too) is seen, never undone.
    std::error_code ec;
    const std::uint64_t bytes = fs::file_size(file_of(m_dir, id, kExtension), ec);
    if (ec) return false;
    m_files.emplace(id, File{bytes, ++m_generations});
    m_bytes += bytes;
    return true;
}

std::uint64_t TextonDirectory::generation_locked(const std::string& id) const {
    const auto it = m_files.find(id);
    return it == m_files.end() ? 0 : it->second.generation;
}

void TextonDirectory::scan() {
    // What a crash left is older than this process. The filesystem's own clock says what is
    // older (a file written now, on a server whose clock differs, must not look old): a marker's
    // time, written as the scan starts.
    const std::string marker = (fs::path(m_dir) / (".scan-" + std::to_string(::getpid()))).string();
    { std::ofstream(marker).put('\n'); }
    std::error_code ec;
    const auto opened = fs::last_write_time(marker, ec);
    if (!ec) m_opened = opened;
    fs::remove(marker, ec);
    const auto started = std::chrono::steady_clock::now();
    std::size_t names = 0;
    const bool listed = index_names(names);
    // Exemplars and provenance of textons never completed (a crash between the writes): only
    // after a whole listing, which says what is complete.
    if (listed) clear_orphans();
    std::lock_guard lock(m_mutex);
    m_indexed = true;
    m_indexed_cv.notify_all();
    spdlog::info("store: {} texton files indexed in {} ms", names,
                 std::chrono::duration_cast<std::chrono::milliseconds>(
                     std::chrono::steady_clock::now() - started)
                     .count());
}

bool TextonDirectory::left_by_a_crash(const fs::directory_entry& e) const {
    std::error_code ec;
    const auto t = e.last_write_time(ec);
    return m_opened && !ec && t < *m_opened;
}

bool TextonDirectory::index_names(std::size_t& names) {
    std::error_code ec;
    for (fs::directory_iterator it(m_dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (unfinished(name)) { // a write a crash interrupted: never complete, never referenced
            if (left_by_a_crash(*it)) {
                std::error_code rm;
                fs::remove(it->path(), rm);
                spdlog::warn("store: removed an unfinished write {}", name);
            }
            continue;
        }
        const std::string stem = it->path().stem().string();
        if (it->path().extension() != kExtension || !api::is_texton_id(stem)) {
            spdlog::warn("store: ignoring {} (not a texton file name)", name);
            continue;
        }
        std::lock_guard lock(m_mutex);
        if (m_stopping) return false;
        names += index_locked(stem) ? 1 : 0;
    }
    if (ec)
        spdlog::error("store: cannot list {}: {}; what crashes left stays until a restart", m_dir,
                      ec.message());
    return !ec;
}

void TextonDirectory::clear_orphans() {
    for (const std::string& dir : {m_exemplars, m_provenance}) {
        std::error_code ec;
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string name = it->path().filename().string();
            const std::string stem = it->path().stem().string();
            std::lock_guard lock(m_mutex);
            if (m_stopping) return;
            const bool writing =
                std::find(m_writing.begin(), m_writing.end(), stem) != m_writing.end();
            if ((unfinished(name) || !m_files.count(stem)) && !writing && left_by_a_crash(*it)) {
                std::error_code rm;
                fs::remove(it->path(), rm);
            }
        }
    }
}

void TextonDirectory::wait_indexed() const {
    std::unique_lock lock(m_mutex);
    m_indexed_cv.wait(lock, [this] { return m_indexed || m_stopping; });
}

void TextonDirectory::drop_locked(const std::string& id) {
    if (auto it = m_files.find(id); it != m_files.end()) {
        m_bytes -= std::min(m_bytes, it->second.bytes);
        m_files.erase(it);
    }
    if (auto it = m_meta.find(id); it != m_meta.end()) {
        m_ages.erase(it->second.age);
        m_meta.erase(it);
    }
}

void TextonDirectory::remember_locked(const std::string& id, api::TextonMeta meta) {
    if (auto it = m_meta.find(id); it != m_meta.end()) {
        it->second.meta = std::move(meta);
        m_ages.splice(m_ages.begin(), m_ages, it->second.age);
        return;
    }
    m_ages.push_front(id);
    m_meta.emplace(id, Cached{std::move(meta), m_ages.begin()});
    while (m_meta.size() > m_meta_capacity) {
        m_meta.erase(m_ages.back());
        m_ages.pop_back();
    }
}

bool TextonDirectory::quarantine_locked(const std::string& id, const std::string& why) {
    const fs::path from = file_of(m_dir, id, kExtension);
    const std::string name = id + kExtension + "." +
                             std::to_string(std::chrono::system_clock::now().time_since_epoch() /
                                            std::chrono::milliseconds(1));
    std::error_code ec;
    const bool gone = !fs::exists(from, ec) && !ec; // removed behind the server's back
    if (!gone) {
        fs::rename(from, fs::path(m_quarantine) / name, ec);
        if (ec) fs::remove(from, ec); // never leave it where it could be served
    }
    fs::remove(file_of(m_exemplars, id, ".png"), ec);
    fs::remove(file_of(m_provenance, id, ".json"), ec);
    drop_locked(id);
    if (gone) {
        spdlog::warn("store: texton {} is no longer on disk (removed outside the server); "
                     "forgotten",
                     id);
        return false;
    }
    m_quarantined.add(name);
    spdlog::error("store: texton {} is damaged ({}); moved to {}/{}", id, why, m_quarantine, name);
    return true;
}

std::optional<api::TextonMeta> TextonDirectory::meta(const std::string& id) {
    if (!api::is_texton_id(id)) return std::nullopt;
    std::uint64_t generation = 0;
    {
        std::lock_guard lock(m_mutex);
        if (!m_files.count(id) && (m_indexed || !index_locked(id))) return std::nullopt;
        if (auto it = m_meta.find(id); it != m_meta.end()) {
            m_ages.splice(m_ages.begin(), m_ages, it->second.age);
            return it->second.meta;
        }
        generation = generation_locked(id);
    }
    // First sight (or evicted): read and verified outside the lock, as load() does.
    auto r = io::read_texton_file(file_of(m_dir, id, kExtension));
    std::optional<api::TextonMeta> meta;
    if (r && r.value().meta.id == id)
        meta = with_provenance(file_of(m_provenance, id, ".json"), std::move(r.value().meta));
    std::lock_guard lock(m_mutex);
    if (generation_locked(id) != generation) return std::nullopt; // erased or rewritten meanwhile
    if (!meta) {
        quarantine_locked(id, r ? "its metadata names another id" : r.error().message);
        return std::nullopt;
    }
    remember_locked(id, *meta);
    return meta;
}

bool TextonDirectory::contains(const std::string& id) {
    if (!api::is_texton_id(id)) return false;
    std::lock_guard lock(m_mutex);
    return m_files.count(id) != 0 || (!m_indexed && index_locked(id));
}

Result<io::TextonRecord> TextonDirectory::load(const std::string& id) {
    if (!contains(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    std::uint64_t generation = 0;
    {
        std::lock_guard lock(m_mutex);
        generation = generation_locked(id);
    }
    auto r = io::read_texton_file(file_of(m_dir, id, kExtension));
    if (!r || r.value().meta.id != id) {
        std::lock_guard lock(m_mutex);
        if (generation != 0 && generation_locked(id) == generation &&
            !quarantine_locked(id, r ? "its metadata names another id" : r.error().message))
            return make_error(ErrorCode::not_found,
                              "texton " + id +
                                  " is no longer on disk (removed outside the server)");
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

TextonDirectory::WritingMark::WritingMark(TextonDirectory& d, const std::string& id)
    : m_d(d), m_id(id) {
    std::lock_guard lock(m_d.m_mutex);
    m_d.m_writing.push_back(m_id);
}

TextonDirectory::WritingMark::~WritingMark() {
    std::lock_guard lock(m_d.m_mutex);
    m_d.m_writing.erase(std::find(m_d.m_writing.begin(), m_d.m_writing.end(), m_id));
}

Result<bool> TextonDirectory::write(const std::string& id, const std::string& file,
                                    const std::string* exemplar_png,
                                    const nlohmann::json& provenance) {
    const std::string path = file_of(m_dir, id, kExtension);
    const std::string exemplar = file_of(m_exemplars, id, ".png");
    const std::string told = file_of(m_provenance, id, ".json");
    std::error_code ec;
    const WritingMark writing(*this, id);
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
    {
        // From here a reader of the old file must not quarantine the new one it may now see.
        std::lock_guard lock(m_mutex);
        drop_locked(id);
    }
    fsync_directory(m_dir);
    io::crash_point("texton-synced");
    auto r = io::read_texton_file(path);
    if (!r || r.value().meta.id != id) {
        fs::remove(path, ec);
        undo();
        spdlog::error("store: texton {} fails verification: {}", id,
                      r ? "its metadata names another id" : r.error().message);
        // The file's own code when it cannot be read at all (not_found); otherwise the bytes
        // are at fault, not this disk: unprocessable.
        if (!r && r.error().code != ErrorCode::unprocessable) return r.error();
        return make_error(ErrorCode::unprocessable,
                          "texton " + id + " fails verification; it is not served");
    }
    api::TextonMeta meta = std::move(r.value().meta);
    api::read_provenance(provenance, meta);
    const std::uint64_t bytes = fs::file_size(path, ec);
    std::lock_guard lock(m_mutex);
    drop_locked(id); // a rewrite of the same id (content-addressed: the same texton)
    m_files[id] = File{ec ? 0 : bytes, ++m_generations};
    m_bytes += ec ? 0 : bytes;
    remember_locked(id, std::move(meta));
    return true;
}

Result<bool> TextonDirectory::erase(const std::string& id, bool regardless) {
    if (!api::is_texton_id(id)) return false;
    {
        std::lock_guard lock(m_mutex);
        if (!m_files.count(id) && (m_indexed || !index_locked(id))) return false;
        std::error_code ec;
        fs::remove(file_of(m_dir, id, kExtension), ec);
        if (ec && !regardless)
            return make_error(ErrorCode::io, "cannot delete texton " + id + ": " + ec.message());
        fs::remove(file_of(m_exemplars, id, ".png"), ec);
        fs::remove(file_of(m_provenance, id, ".json"), ec);
        drop_locked(id);
    }
    // Outside the lock: every lookup waited on this disk flush before.
    fsync_directory(m_dir);
    return true;
}

std::vector<std::string> TextonDirectory::ids(const std::string& after, int limit) const {
    wait_indexed();
    std::vector<std::string> out;
    std::lock_guard lock(m_mutex);
    for (auto it = after.empty() ? m_files.begin() : m_files.upper_bound(after);
         it != m_files.end() && static_cast<int>(out.size()) < limit; ++it)
        out.push_back(it->first);
    return out;
}

std::vector<api::TextonMeta> TextonDirectory::list(const std::string& after, int limit) {
    std::vector<api::TextonMeta> out;
    std::string cursor = after;
    // A damaged file found on the way is quarantined and the page filled from the next ids, so
    // a short page still means the end.
    while (static_cast<int>(out.size()) < limit) {
        const std::vector<std::string> page = ids(cursor, limit - static_cast<int>(out.size()));
        if (page.empty()) break;
        for (const std::string& id : page)
            if (auto m = meta(id)) out.push_back(std::move(*m));
        cursor = page.back();
    }
    return out;
}

std::size_t TextonDirectory::count() const {
    std::lock_guard lock(m_mutex);
    return m_files.size();
}

std::uint64_t TextonDirectory::bytes() const {
    std::lock_guard lock(m_mutex);
    return m_bytes;
}

std::size_t TextonDirectory::quarantined_count() const {
    std::lock_guard lock(m_mutex);
    return m_quarantined.count();
}

std::vector<std::string> TextonDirectory::quarantined() const {
    std::lock_guard lock(m_mutex);
    return m_quarantined.names();
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

std::optional<std::uint64_t> TextonDirectory::free_bytes() const {
    struct statvfs v {};
    if (::statvfs(m_dir.c_str(), &v) != 0) return std::nullopt;
    return static_cast<std::uint64_t>(v.f_bavail) * v.f_frsize;
}

} // namespace textond::store
