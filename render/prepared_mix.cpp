#include "render/prepared_mix.h"

#include "render/table_budget.h"

#include <algorithm>

namespace textond::render {

Result<std::shared_ptr<const PreparedMix>> PreparedMix::make(std::vector<core::Texton> levels,
                                                             core::MixField field) {
    if (levels.size() < 2)
        return make_error(ErrorCode::invalid_argument, "a mix needs at least two levels");
    if (auto err = field.validate()) return *err;
    std::shared_ptr<PreparedMix> m(new PreparedMix());
    for (auto& t : levels) {
        if (t.size != levels.front().size || t.order != levels.front().order ||
            t.channels != levels.front().channels)
            return make_error(ErrorCode::invalid_argument,
                              "mix levels must share size, order and channels");
        auto p = PreparedTexton::make(std::move(t));
        if (!p) return p.error();
        m->m_levels.push_back(p.value());
    }
    m->m_field = std::move(field);
    return std::shared_ptr<const PreparedMix>(std::move(m));
}

std::shared_ptr<const PreparedMix::Tables> PreparedMix::tables(int level) const {
    const int key = std::max(0, level);
    std::shared_ptr<const Tables> set;
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        auto& kept = m_tables[key];
        set = kept.lock();
        if (!set) {
            auto made = std::make_shared<Tables>();
            for (const auto& l : m_levels) made->push_back(l->derived_table(key));
            set = made;
            kept = set;
        }
    }
    std::size_t bytes = 0;
    for (const auto& t : *set) bytes += level_table_bytes(*t);
    TableBudget::instance().use(set, bytes);
    return set;
}

double PreparedMix::mean_of(double rho, int c) const {
    const auto ci = static_cast<std::size_t>(c);
    return (1.0 - rho) * m_levels.front()->texton().mean[ci] +
           rho * m_levels.back()->texton().mean[ci];
}

std::optional<Error> PreparedMix::check(const NoiseRequest& q) const {
    if (q.period[0] != 0 || q.period[1] != 0)
        return make_error(ErrorCode::invalid_argument,
                          "mixes have no tileable mode: the field rho(x) is not periodic");
    if (q.marginals == Marginals::exemplar)
        return make_error(ErrorCode::invalid_argument,
                          "mixes have no exemplar marginals (two exemplars, one field between "
                          "them); use marginals=gaussian");
    return m_levels.front()->check(q);
}

} // namespace textond::render
