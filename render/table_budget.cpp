#include "render/table_budget.h"

#include <vector>

namespace textond::render {

TableBudget& TableBudget::instance() {
    static TableBudget budget;
    return budget;
}

void TableBudget::set_limit(std::size_t bytes) {
    std::lock_guard lock(m_mutex);
    m_limit = bytes;
}

std::size_t TableBudget::limit() const {
    std::lock_guard lock(m_mutex);
    return m_limit;
}

std::size_t TableBudget::bytes() const {
    std::lock_guard lock(m_mutex);
    return m_bytes;
}

void TableBudget::use(std::shared_ptr<const void> item, std::size_t bytes) {
    std::vector<std::shared_ptr<const void>> let_go; // freed after the lock, if no one uses them
    std::lock_guard lock(m_mutex);
    if (auto it = m_where.find(item.get()); it != m_where.end()) {
        m_recent.splice(m_recent.begin(), m_recent, it->second);
    } else {
        m_recent.emplace_front(std::move(item), bytes);
        m_where.emplace(m_recent.front().first.get(), m_recent.begin());
        m_bytes += bytes;
    }
    while (m_bytes > m_limit && m_recent.size() > 1) {
        m_bytes -= m_recent.back().second;
        m_where.erase(m_recent.back().first.get());
        let_go.push_back(std::move(m_recent.back().first));
        m_recent.pop_back();
    }
}

} // namespace textond::render
