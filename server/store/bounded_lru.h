#pragma once
// The prepared objects a store keeps in memory (splat_store.h, mix_store.h): at most `capacity`
// of them and `budget_bytes` in all, least recently used out first, but never the last one, so
// that an object larger than the budget can still be served once it is loaded. An Entry has an
// `id` (std::string) and its `bytes`. Not thread-safe: the store locks around it.
#include <cstddef>
#include <list>
#include <optional>
#include <string>

namespace textond::store {

template <typename Entry> class BoundedLru {
public:
    BoundedLru(std::size_t capacity, std::size_t budget_bytes)
        : m_capacity(capacity), m_budget(budget_bytes) {}

    // A copy of the entry, made the most recent.
    std::optional<Entry> get(const std::string& id) {
        for (auto it = m_entries.begin(); it != m_entries.end(); ++it)
            if (it->id == id) {
                m_entries.splice(m_entries.begin(), m_entries, it);
                return *it;
            }
        return std::nullopt;
    }

    // Kept as the most recent, in place of one with its id; then the least recent out.
    void put(Entry e) {
        erase(e.id);
        m_bytes += e.bytes;
        m_entries.push_front(std::move(e));
        while (m_entries.size() > 1 && (m_entries.size() > m_capacity || m_bytes > m_budget)) {
            m_bytes -= m_entries.back().bytes;
            m_entries.pop_back();
        }
    }

    void erase(const std::string& id) {
        for (auto it = m_entries.begin(); it != m_entries.end(); ++it)
            if (it->id == id) {
                m_bytes -= it->bytes;
                m_entries.erase(it);
                return;
            }
    }

    std::size_t size() const { return m_entries.size(); }
    std::size_t bytes() const { return m_bytes; }

private:
    std::size_t m_capacity, m_budget;
    std::list<Entry> m_entries; // front: the most recent
    std::size_t m_bytes = 0;
};

} // namespace textond::store
