#include "core/grid_poisson.h"

#include "core/noise_hash.h"

#include <cmath>
#include <stdexcept>

namespace textond::core::noise {

double exp_neg(double mu) {
    if (!(mu >= 0.0 && mu <= 100.0)) throw std::invalid_argument("exp_neg: mu outside [0, 100]");
    const double x = mu / 1024.0;
    double s = 1.0, term = 1.0;
    for (int n = 1; n <= 16; ++n) {
        term = term * (-x) / n;
        s = s + term;
    }
    for (int i = 0; i < 10; ++i) s = s * s;
    return s;
}

std::vector<std::uint32_t> poisson_thresholds(double mu) {
    const double e = exp_neg(mu);
    double p = e, f = e;
    std::vector<std::uint32_t> t;
    for (int j = 0; static_cast<int>(t.size()) < kMaxThresholds; ++j) {
        if (j > 0) {
            p = p * mu / j;
            f = f + p;
        }
        const double v = std::floor(f * 4294967296.0);
        if (v >= 4294967295.0) break;
        t.push_back(static_cast<std::uint32_t>(v));
    }
    return t;
}

GridPoisson::GridPoisson(int texton_size, double mni_, std::array<std::int64_t, 2> period_)
    : r(texton_size), a(cell_size(texton_size)), mni(mni_), period(period_) {
    if (r < 1) throw std::invalid_argument("GridPoisson: texton size < 1");
    if (!(mni >= kMinMni && mni <= kMaxMni))
        throw std::invalid_argument("GridPoisson: MNI outside [1, 200]");
    lambda = mni / (static_cast<double>(r) * r);
    mu = lambda * a * a;
    thresholds = poisson_thresholds(mu);
}

int GridPoisson::cell_points(std::uint64_t seed, std::int64_t cx, std::int64_t cy,
                             std::vector<CellPoint>& out) const {
    const std::int64_t kx = period[0] > 0 ? floor_mod(cx, period[0]) : cx;
    const std::int64_t ky = period[1] > 0 ? floor_mod(cy, period[1]) : cy;
    Stream32 s(cell_key(seed, kx, ky));
    const int n = poisson_count(thresholds.data(), static_cast<int>(thresholds.size()), s.next());
    const std::uint64_t ua = static_cast<std::uint64_t>(a);
    for (int i = 0; i < n; ++i) {
        const std::uint64_t px = s.next() * ua, py = s.next() * ua;
        const std::uint32_t de = s.next();
        CellPoint p;
        p.bx = cx * a + static_cast<std::int64_t>(px >> 32);
        p.by = cy * a + static_cast<std::int64_t>(py >> 32);
        p.fx = static_cast<std::uint32_t>(px & 0xffffffffu) >> 8;
        p.fy = static_cast<std::uint32_t>(py & 0xffffffffu) >> 8;
        p.eps = (de >> 31) == 0 ? 1.0f : -1.0f;
        out.push_back(p);
    }
    return n;
}

} // namespace textond::core::noise
