#pragma once
// Encoded images (tiles, regions, tileable textures) kept in memory under a byte budget, least
// recently used out first. Values are immutable and shared, so a hit copies no pixels under the
// lock and a response can outlive its eviction.
#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace textond::store {

struct CachedImage {
    CachedImage() = default;
    CachedImage(const CachedImage&) = delete;
    CachedImage& operator=(const CachedImage&) = delete;
    ~CachedImage(); // its body's memory goes back to the encoder (io::recycle_encoded)
    std::string body;
    std::string etag; // quoted, strong
    std::string content_type;
    std::string texton_id; // so DELETE can drop every image of a texton
};

class ImageCache {
public:
    explicit ImageCache(std::size_t budget_bytes) : m_budget(budget_bytes) {}

    std::shared_ptr<const CachedImage> get(const std::string& key);
    // Entries larger than an eighth of the budget are not kept: one region must not flush every
    // tile.
    void put(const std::string& key, std::shared_ptr<const CachedImage> value);
    void erase_texton(const std::string& texton_id);

    std::size_t bytes() const;
    std::size_t entries() const;
    std::size_t budget() const { return m_budget; }

private:
    struct Entry {
        std::string key;
        std::shared_ptr<const CachedImage> value;
        std::size_t cost;
    };
    static std::size_t cost_of(const std::string& key, const CachedImage& v);
    void evict_locked();

    const std::size_t m_budget;
    mutable std::mutex m_mutex;
    std::list<Entry> m_lru; // front = most recent
    std::unordered_map<std::string, std::list<Entry>::iterator> m_index;
    std::size_t m_bytes = 0;
};

} // namespace textond::store
