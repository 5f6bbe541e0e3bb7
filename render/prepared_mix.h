#pragma once
// A texture mix made ready for evaluation (texton-noise section 7): R prepared level textons that
// share r, order and channels, and the field rho(x) that picks the level of every Poisson point.
#include "core/texture_mix.h"
#include "render/prepared_texton.h"

#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace textond::render {

class PreparedMix {
public:
    static Result<std::shared_ptr<const PreparedMix>> make(std::vector<core::Texton> levels,
                                                           core::MixField field);

    int levels() const { return static_cast<int>(m_levels.size()); }
    const PreparedTexton& level(int l) const { return *m_levels[static_cast<std::size_t>(l)]; }
    const core::MixField& field() const { return m_field; }
    int size() const { return m_levels.front()->size(); }
    int channels() const { return m_levels.front()->channels(); }

    // The level of a point at (x, y) texels, and the mean colour channel c at (x, y): the linear
    // interpolation (1 - rho) m_u + rho m_v of the two ends' means. Where one rho serves several
    // uses, take it once with field().rho and use level_of / mean_of.
    int level_at(double x, double y) const { return level_of(m_field.rho(x, y)); }
    double mean_at(double x, double y, int c) const { return mean_of(m_field.rho(x, y), c); }
    int level_of(double rho) const { return core::mix_level(rho, levels()); }
    double mean_of(double rho, int c) const;

    std::optional<Error> check(const NoiseRequest& req) const;

    // Every level's table at `level` (of the output), in level order: one item of the table
    // budget, kept or let go together. A tile of a mix reads them all in turn, and tables let go
    // one by one were each let go before the next tile came back to them: a mix larger than the
    // budget built all its tables again for every tile.
    using Tables = std::vector<std::shared_ptr<const LevelTable>>;
    std::shared_ptr<const Tables> tables(int level) const;

private:
    PreparedMix() = default;
    std::vector<std::shared_ptr<const PreparedTexton>> m_levels;
    core::MixField m_field;
    mutable std::mutex m_mutex;
    mutable std::map<int, std::weak_ptr<const Tables>> m_tables; // kept by the table budget
};

} // namespace textond::render
