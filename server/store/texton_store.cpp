#include "server/store/texton_store.h"

#include "api/safe_text.h"

#include "server/io/image_io.h"
#include "server/store/read_through.h"

#include <spdlog/spdlog.h>

#include <malloc.h>

namespace textond::store {

TextonStore::TextonStore(std::unique_ptr<TextonDirectory> local, std::size_t prepared_cache,
                         std::unique_ptr<store::RedisStore> shared,
                         std::chrono::milliseconds recheck)
    : m_local(std::move(local)), m_prepared_capacity(prepared_cache == 0 ? 1 : prepared_cache),
      m_shared(std::move(shared)), m_recheck(recheck) {
    if (m_shared) m_sweeper.emplace(m_recheck, [this] { sweep(); });
}

void TextonStore::sweep() {
    std::string after;
    for (;;) {
        const std::vector<api::TextonMeta> page = m_local->list(after, 256);
        if (page.empty()) return;
        for (const api::TextonMeta& meta : page) {
            if (m_sweeper->stopping()) return;
            {
                std::lock_guard lock(m_mutex);
                m_checked[meta.id] = std::chrono::steady_clock::now();
            }
            if (!m_shared->presence(meta.id)) return; // down: try again next round
            (void)recheck(meta.id, meta);
        }
        after = page.back().id;
    }
}

Result<std::unique_ptr<TextonStore>> TextonStore::open(const std::string& data_dir,
                                                       std::size_t prepared_cache,
                                                       std::unique_ptr<store::RedisStore> shared,
                                                       std::chrono::milliseconds recheck,
                                                       std::size_t meta_cache) {
    auto local = TextonDirectory::open(data_dir, meta_cache);
    if (!local) return local.error();
    std::unique_ptr<TextonStore> s(
        new TextonStore(std::move(local.value()), prepared_cache, std::move(shared), recheck));
    spdlog::info("store: {}{}", s->m_local->path(),
                 s->m_shared ? " (a cache of " + s->m_shared->describe() + ")" : "");
    return s;
}

void TextonStore::forget(const std::string& id) {
    std::lock_guard lock(m_mutex);
    m_checked.erase(id);
    m_exemplars_decoded.erase(id);
    m_prepared.remove_if([&](const auto& p) { return p.first == id; });
}

Result<api::TextonMeta> TextonStore::find(const std::string& id, bool now_) {
    auto local = m_local->meta(id);
    if (!local) {
        if (!m_shared) return make_error(ErrorCode::not_found, "no texton " + id);
        return fetch_shared(id);
    }
    if (!m_shared) return std::move(*local);
    {
        std::lock_guard lock(m_mutex);
        const auto now = std::chrono::steady_clock::now();
        auto& checked = m_checked[id];
        if (!now_ && now < checked + m_recheck) return std::move(*local);
        checked = now; // one request per interval makes the round trip
    }
    return recheck(id, std::move(*local));
}

Result<api::TextonMeta> TextonStore::recheck(const std::string& id, api::TextonMeta local) {
    auto presence = m_shared->presence(id);
    if (!presence) return local; // the shared store is down: serve what we hold
    switch (presence.value()) {
    case store::RedisStore::Presence::present:
        // A damaged or replaced entry is rewritten from this verified copy.
        if (auto file = m_local->file(id)) {
            auto exemplar = m_local->exemplar(id);
            const nlohmann::json meta = local;
            auto fixed = m_shared->repair_if_differs(id, file.value(), meta.dump(),
                                                     exemplar ? exemplar.value() : "");
            if (fixed && fixed.value())
                spdlog::warn("store: texton {} was damaged in the shared store; repaired", id);
        }
        return local;
    case store::RedisStore::Presence::deleted:
        (void)m_local->erase(id, true); // never served here again, even if its file stays
        forget(id);
        spdlog::info("store: texton {} was deleted from the shared store; dropped here", id);
        return make_error(ErrorCode::not_found, "no texton " + id + " (deleted)");
    case store::RedisStore::Presence::unknown:
        break;
    }
    // Held here but absent there (a flushed Redis, or stored before the shared store was
    // configured): write it back so the other replicas find it.
    if (m_creating.contains(id)) return local; // its upload stores it in a moment
    auto file = m_local->file(id);
    auto exemplar = m_local->exemplar(id);
    if (file) {
        const nlohmann::json meta = local;
        auto put = m_shared->put(id, file.value(), meta.dump(), exemplar ? exemplar.value() : "",
                                 /*write_back=*/true);
        if (put && put.value())
            spdlog::warn("store: texton {} was missing from the shared store; written back", id);
    }
    return local;
}

Result<api::TextonMeta> TextonStore::fetch_shared(const std::string& id) {
    auto result = m_fetches.run(id, [&] { return fetch_shared_once(id); });
    // The values were large transient buffers (an exemplar of up to 112 MiB): give the freed
    // pages back rather than keep them in the arenas.
    ::malloc_trim(0);
    return result;
}

Result<api::TextonMeta> TextonStore::fetch_shared_once(const std::string& id) {
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
        provenance = nlohmann::json::object(); // absent or unreadable: served without it
    }
    const std::string signature = got.value()->signature;
    auto w = m_local->write(id, got.value()->file, &got.value()->exemplar_png, provenance);
    if (!w) {
        // Values that pass their checksums but fail the file's own checks (another id's
        // metadata, coefficients that disagree): not read again while they stay the same. A
        // full or failing disk here says nothing of them (it had got a valid texton refused on
        // this replica for a minute after the disk had room again).
        if (w.error().code != ErrorCode::unprocessable)
            return read_through_error("texton " + id, w.error());
        m_shared->refuse_texton(id, signature);
        return make_error(ErrorCode::io, w.error().message);
    }
    const std::size_t exemplar_bytes = got.value()->exemplar_png.size();
    got.value().reset();
    {
        std::lock_guard lock(m_mutex);
        m_checked[id] = std::chrono::steady_clock::now();
    }
    auto meta = m_local->meta(id);
    if (!meta) return make_error(ErrorCode::not_found, "no texton " + id);
    // The exemplar was bounded by the shared store's metadata (text); the verified file's own
    // exemplar size must bound it too, or the copy is dropped as damaged.
    if (static_cast<long long>(exemplar_bytes) >
        RedisStore::exemplar_cap(meta->exemplar_width, meta->exemplar_height)) {
        (void)m_local->erase(id);
        forget(id);
        m_shared->refuse_texton(id, signature);
        spdlog::error("store: texton {} in the shared store has an exemplar of {} bytes, more "
                      "than its {}x{} exemplar holds; not kept",
                      id, exemplar_bytes, meta->exemplar_width, meta->exemplar_height);
        return make_error(ErrorCode::io, "texton " + id +
                                             " in the shared store has an exemplar larger than "
                                             "it can hold; it is not served");
    }
    return std::move(*meta);
}

Result<io::TextonRecord> TextonStore::record(const std::string& id) {
    if (!m_local->contains(id))
        if (auto found = find(id); !found) return found.error();
    auto r = m_local->load(id);
    if (!r) forget(id); // quarantined, or deleted meanwhile
    return r;
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
    auto r = record(id);
    if (!r) return r.error();
    auto p = render::PreparedTexton::make(std::move(r.value().texton));
    if (!p) return p.error();
    std::lock_guard lock(m_mutex);
    // A remove erases the file before it takes m_mutex to forget: either it is seen here, or
    // its forget comes after this insertion.
    if (!m_local->contains(id)) return make_error(ErrorCode::not_found, "no texton " + id);
    for (auto it = m_prepared.begin(); it != m_prepared.end(); ++it)
        if (it->first == id) return it->second; // another thread won the race
    m_prepared.emplace_front(id, p.value());
    while (m_prepared.size() > m_prepared_capacity) m_prepared.pop_back();
    return p.value();
}

Result<std::string> TextonStore::file_bytes(const std::string& id) {
    auto r = record(id);
    if (!r) return r.error();
    return m_local->file(id);
}

Result<bool> TextonStore::put(io::TextonRecord record, const core::Image* exemplar) {
    const std::string id = record.meta.id;
    // Held here (and whole: a damaged copy is quarantined by the check and written afresh); a
    // copy only the shared store holds is found by its write-if-absent below.
    if (m_local->meta(id)) return false;
    record.meta.created = api::rfc3339_now();
    std::string png;
    if (exemplar) {
        auto p = io::encode_image_memory(*exemplar, io::Encoding::png8, {}, 6);
        if (!p) return p.error();
        png = std::move(p.value());
    }
    auto file = io::texton_file_bytes(record);
    if (!file) return file.error();
    // Here first, then the shared store: an upload this disk cannot hold (507) leaves nothing
    // for the other replicas to serve; it had been stored for them all the same.
    const InFlightIds::Mark creating(m_creating, id);
    auto w = m_local->write(id, file.value(), &png, api::provenance_json(record.meta));
    // A texton this server made that fails its own verification is the server's fault (500).
    if (!w && w.error().code == ErrorCode::unprocessable)
        return make_error(ErrorCode::internal, w.error().message);
    if (!w) return w.error();
    if (m_shared) {
        const nlohmann::json meta = record.meta;
        auto stored = m_shared->put(id, file.value(), meta.dump(), png);
        if (!stored || !stored.value()) {
            (void)m_local->erase(id);
            forget(id);
            if (!stored) return stored.error();
            auto adopted = fetch_shared(id); // another replica stored it first: adopt that one
            if (!adopted) return adopted.error();
            return false;
        }
    }
    std::lock_guard lock(m_mutex);
    m_checked[id] = std::chrono::steady_clock::now();
    return true;
}

Result<bool> TextonStore::remove(const std::string& id) {
    if (m_shared) {
        auto r = m_shared->remove(id);
        if (!r) return r.error();
        if (!r.value() && !m_local->contains(id))
            return make_error(ErrorCode::not_found, "no texton " + id);
    }
    auto erased = m_local->erase(id);
    if (!erased) return erased.error();
    forget(id);
    if (!erased.value() && !m_shared) return make_error(ErrorCode::not_found, "no texton " + id);
    return true; // with a shared store: deleted there, perhaps never fetched here
}

Result<std::string> TextonStore::exemplar_png(const std::string& id) {
    if (auto found = find(id); !found) return found.error();
    auto png = m_local->exemplar(id);
    if (!png && png.error().code == ErrorCode::not_found)
        return make_error(ErrorCode::not_found,
                          "texton " + id +
                              " has no stored exemplar: stored before exemplars were kept, or "
                              "removed from the disk since");
    // The file was written whole (atomic_file.h): a PNG cut short was damaged since, on this
    // disk; it is never served as the exemplar, nor blamed on the client (500, not 422).
    if (png && !io::png_complete(png.value()))
        return make_error(ErrorCode::io, "the stored exemplar of texton " + id +
                                             " is damaged (a PNG chunk runs past its end)");
    return png;
}

Result<core::Image> TextonStore::decode_exemplar(const std::string& id, const std::string& png) {
    io::DecodeLimits stored; // admitted once under --max-pixels, which is at most 2^32
    stored.max_pixels = std::uint64_t{1} << 32;
    auto image = io::decode_image_memory(png, stored);
    if (!image)
        return make_error(ErrorCode::io, "the stored exemplar of texton " + id +
                                             " does not decode: " + image.error().message);
    std::lock_guard lock(m_mutex);
    m_exemplars_decoded.insert(id);
    return image;
}

Result<core::Image> TextonStore::exemplar_image(const std::string& id) {
    auto png = exemplar_png(id);
    if (!png) return png.error();
    return decode_exemplar(id, png.value());
}

Result<std::string> TextonStore::verified_exemplar_png(const std::string& id) {
    auto png = exemplar_png(id);
    if (!png) return png;
    bool decoded = false;
    {
        std::lock_guard lock(m_mutex);
        decoded = m_exemplars_decoded.count(id) != 0;
    }
    if (!decoded)
        if (auto image = decode_exemplar(id, png.value()); !image) return image.error();
    return png;
}

Result<std::vector<api::TextonMeta>> TextonStore::list(const std::string& after, int limit,
                                                       std::string* resume) {
    if (resume) resume->clear();
    if (!m_shared) return m_local->list(after, limit);
    bool more = false;
    auto metas = m_shared->list_meta(after, limit, &more);
    if (!metas) return metas.error();
    if (more && resume && !metas.value().empty()) *resume = metas.value().back().first;
    // A verified local copy's metadata wins over what Redis says; Redis metadata naming another
    // id than its key's is not listed (the key is the content address, the JSON is just text).
    std::vector<api::TextonMeta> out;
    for (const auto& [id, text] : metas.value()) {
        if (auto held = m_local->meta(id)) {
            out.push_back(std::move(*held));
            continue;
        }
        try {
            auto meta = nlohmann::json::parse(text).get<api::TextonMeta>();
            if (meta.id != id) {
                spdlog::error("store: the shared store's metadata of {} names {}; not listed", id,
                              api::printable(meta.id, 80));
                continue;
            }
            out.push_back(std::move(meta));
        } catch (const std::exception& e) {
            spdlog::error("store: unreadable metadata of {} in the shared store: {}", id, e.what());
        }
    }
    return out;
}

Result<std::uint64_t> TextonStore::total() {
    if (m_shared) return m_shared->count();
    return static_cast<std::uint64_t>(m_local->count());
}

} // namespace textond::store
