#pragma once
// What prepared textons derive from their coefficients, within one byte budget: the level tables
// (one a level, NOISE_SPEC.md section 6, with a phase-split copy at zoomed-out levels) and the lag
// covariance the limit levels and marginals read. A colour texton of r = 256 derives up to 80 MB
// of tables and 19 MB of covariance once every level has been asked for; they were kept as long
// as the texton stayed prepared, so the 64 textons the store keeps prepared, or one mix of 64
// levels (a texton a level), held 2 to 5 GB. Here the most recently used are kept, up to the
// budget; one past it is let go, freed when the last render using it ends, and derived again when
// asked for. The budget is process-wide (serve's --table-cache-mb).
#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <utility>

namespace textond::render {

class TableBudget {
public:
    static TableBudget& instance();
    // Bytes kept at most (the one just used is kept whatever its size).
    void set_limit(std::size_t bytes);
    std::size_t limit() const;
    std::size_t bytes() const; // kept now
    // `item` (of `bytes`) was just used or made: kept as the most recent; the least recent past
    // the budget are let go.
    void use(std::shared_ptr<const void> item, std::size_t bytes);

private:
    TableBudget() = default;
    using Kept = std::pair<std::shared_ptr<const void>, std::size_t>;
    mutable std::mutex m_mutex;
    std::size_t m_limit = std::size_t{256} << 20, m_bytes = 0;
    std::list<Kept> m_recent; // most recent first
    std::unordered_map<const void*, std::list<Kept>::iterator> m_where;
};

} // namespace textond::render
