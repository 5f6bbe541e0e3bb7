#include "server/store/image_cache.h"

#include "server/io/image_io.h"

namespace textond::store {

CachedImage::~CachedImage() {
    io::recycle_encoded(std::move(body));
}

std::size_t ImageCache::cost_of(const std::string& key, const CachedImage& v) {
    // Strings and bookkeeping too, so the budget bounds the process's memory, not just bodies.
    return key.size() * 2 + v.body.size() + v.etag.size() + v.content_type.size() +
           v.texton_id.size() + 160;
}

std::shared_ptr<const CachedImage> ImageCache::get(const std::string& key) {
    std::lock_guard lock(m_mutex);
    auto it = m_index.find(key);
    if (it == m_index.end()) return nullptr;
    m_lru.splice(m_lru.begin(), m_lru, it->second);
    return it->second->value;
}

void ImageCache::put(const std::string& key, std::shared_ptr<const CachedImage> value) {
    if (!value) return;
    const std::size_t cost = cost_of(key, *value);
    if (cost > m_budget / 8) return;
    std::lock_guard lock(m_mutex);
    if (auto it = m_index.find(key); it != m_index.end()) {
        m_bytes -= it->second->cost;
        m_lru.erase(it->second);
        m_index.erase(it);
    }
    m_lru.push_front({key, std::move(value), cost});
    m_index[key] = m_lru.begin();
    m_bytes += cost;
    evict_locked();
}

void ImageCache::erase_texton(const std::string& texton_id) {
    std::lock_guard lock(m_mutex);
    for (auto it = m_lru.begin(); it != m_lru.end();) {
        if (it->value->texton_id == texton_id) {
            m_bytes -= it->cost;
            m_index.erase(it->key);
            it = m_lru.erase(it);
        } else {
            ++it;
        }
    }
}

void ImageCache::evict_locked() {
    while (m_bytes > m_budget && !m_lru.empty()) {
        m_bytes -= m_lru.back().cost;
        m_index.erase(m_lru.back().key);
        m_lru.pop_back();
    }
}

std::size_t ImageCache::bytes() const {
    std::lock_guard lock(m_mutex);
    return m_bytes;
}

std::size_t ImageCache::entries() const {
    std::lock_guard lock(m_mutex);
    return m_index.size();
}

} // namespace textond::store
