#include "core/marginals.h"

#include <algorithm>
#include <cmath>

namespace textond::core {

namespace {

double normal_cdf(double x) {
    return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

// Q(p): the quantile function, linear between the stored quantiles, flat past the ends.
double quantile(const std::vector<float>& q, double p) {
    const int k = static_cast<int>(q.size());
    const double t = std::clamp(p * k - 0.5, 0.0, static_cast<double>(k - 1));
    const int i = std::min(static_cast<int>(t), k - 2);
    const double f = t - i;
    return (1.0 - f) * q[static_cast<std::size_t>(i)] + f * q[static_cast<std::size_t>(i + 1)];
}

// Nodes and weights of E[f(Z)], Z ~ N(0, 1): the trapezoid rule over [-h, h], which converges
// geometrically for smooth integrands; the quantile function has kinks, so the tables take 801
// nodes over [-8, 8] (their expected values then stay within 3e-5 of level 0's), 1601 over
// [-8, 8] check their expected values.
struct NormalRule {
    std::vector<double> z, w;
    NormalRule(int n, double h) {
        double total = 0;
        for (int j = 0; j < n; ++j) {
            const double x = -h + 2.0 * h * j / (n - 1);
            z.push_back(x);
            w.push_back(std::exp(-0.5 * x * x));
            total += w.back();
        }
        for (double& v : w) v /= total;
    }
};

const NormalRule& table_rule() {
    static const NormalRule rule(801, 8.0);
    return rule;
}

const NormalRule& check_rule() {
    static const NormalRule rule(1601, 8.0);
    return rule;
}

} // namespace

// HPG 2018, section 1.3: decorrelate the colours, then one 1-D distribution per component.
MarginalModel marginal_model(const Image& u) {
    MarginalModel m;
    const int nc = u.channels;
    if (nc < 1 || nc > 3 || u.plane_size() == 0) return m;
    m.channels = nc;
    const std::size_t n = u.plane_size();
    for (int c = 0; c < nc; ++c) {
        double s = 0;
        for (std::size_t k = 0; k < n; ++k) s += u.plane(c)[k];
        m.mean[static_cast<std::size_t>(c)] = s / static_cast<double>(n);
    }
    ColourMatrix cov;
    cov.n = nc;
    for (int a = 0; a < nc; ++a)
        for (int b = a; b < nc; ++b) {
            double s = 0;
            for (std::size_t k = 0; k < n; ++k)
                s += (u.plane(a)[k] - m.mean[static_cast<std::size_t>(a)]) *
                     (u.plane(b)[k] - m.mean[static_cast<std::size_t>(b)]);
            cov(a, b) = cov(b, a) = s / static_cast<double>(n);
        }
    ChannelValues w{};
    symmetric_eigen(cov, w, m.basis);
    m.basis.n = nc;
    for (int i = 0; i < nc; ++i) {
        // A sign per eigenvector, fixed by its largest entry: the same basis on every machine.
        int big = 0;
        for (int c = 1; c < nc; ++c)
            if (std::fabs(m.basis(c, i)) > std::fabs(m.basis(big, i))) big = c;
        if (m.basis(big, i) < 0)
            for (int c = 0; c < nc; ++c) m.basis(c, i) = -m.basis(c, i);
        m.variance[static_cast<std::size_t>(i)] = std::max(w[static_cast<std::size_t>(i)], 0.0);
    }
    // Floats, as the pixels are.
    std::vector<float> y(n);
    for (int i = 0; i < nc; ++i) {
        for (std::size_t k = 0; k < n; ++k) {
            double s = 0;
            for (int c = 0; c < nc; ++c)
                s += m.basis(c, i) * (u.plane(c)[k] - m.mean[static_cast<std::size_t>(c)]);
            y[k] = static_cast<float>(s);
        }
        std::sort(y.begin(), y.end());
        auto& q = m.quantiles[static_cast<std::size_t>(i)];
        q.resize(MarginalModel::kQuantiles);
        for (int j = 0; j < MarginalModel::kQuantiles; ++j) {
            const double t = (j + 0.5) / MarginalModel::kQuantiles * static_cast<double>(n) - 0.5;
            const double tc = std::clamp(t, 0.0, static_cast<double>(n - 1));
            const std::size_t lo = static_cast<std::size_t>(tc);
            const std::size_t hi = std::min(lo + 1, n - 1);
            const double f = tc - static_cast<double>(lo);
            q[static_cast<std::size_t>(j)] = static_cast<float>((1.0 - f) * y[lo] + f * y[hi]);
        }
    }
    return m;
}

// HPG 2018, sections 1.4 and 4 (prefiltering): T_0 = Q o Phi(y / sigma_0) maps the level-0
// Gaussian onto the exemplar; the box-averaged level of variance sigma_k^2 gets
// T_k(y) = E[T_0(y + e)], e ~ N(0, sigma_0^2 - sigma_k^2), so E[T_k(Y_k)] = E[T_0(Y_0)].
MarginalTables::MarginalTables(const MarginalModel& m, const std::array<double, 3>& level_variance)
    : m_channels(m.channels), m_basis(m.basis), m_mean(m.mean) {
    const auto& rule = table_rule();
    double total = 0;
    for (int i = 0; i < m.channels; ++i) total += m.variance[static_cast<std::size_t>(i)];
    for (int i = 0; i < m.channels; ++i) {
        const auto ui = static_cast<std::size_t>(i);
        const double v0 = m.variance[ui];
        auto& t = m_tables[ui];
        t.resize(kEntries);
        // A component with no variance (grey stored as RGB, a constant channel) stays as it is.
        if (!(v0 > 1e-12 * total) || !(level_variance[ui] > 0.0)) {
            m_sigma[ui] = std::sqrt(std::max(level_variance[ui], 1e-30));
            for (int j = 0; j < kEntries; ++j)
                t[static_cast<std::size_t>(j)] =
                    static_cast<float>(m_sigma[ui] * (-kRange + 2.0 * kRange * j / (kEntries - 1)));
            continue;
        }
        const double vk = std::min(level_variance[ui], v0);
        const double s0 = std::sqrt(v0), sk = std::sqrt(vk), spread = std::sqrt(v0 - vk);
        m_sigma[ui] = sk;
        const auto& q = m.quantiles[ui];
        for (int j = 0; j < kEntries; ++j) {
            const double y = sk * (-kRange + 2.0 * kRange * j / (kEntries - 1));
            double v = 0;
            if (spread < 1e-9 * s0) {
                v = quantile(q, normal_cdf(y / s0));
            } else {
                for (std::size_t r = 0; r < rule.z.size(); ++r)
                    v += rule.w[r] * quantile(q, normal_cdf((y + spread * rule.z[r]) / s0));
            }
            t[static_cast<std::size_t>(j)] = static_cast<float>(v);
        }
    }
}

double MarginalTables::lookup(int i, double y) const {
    const auto ui = static_cast<std::size_t>(i);
    const double t = std::clamp((y / m_sigma[ui] + kRange) / (2.0 * kRange) * (kEntries - 1), 0.0,
                                static_cast<double>(kEntries - 1));
    const int j = std::min(static_cast<int>(t), kEntries - 2);
    const double f = t - j;
    const auto& tab = m_tables[ui];
    return (1.0 - f) * tab[static_cast<std::size_t>(j)] + f * tab[static_cast<std::size_t>(j + 1)];
}

void MarginalTables::apply(float* v) const {
    double y[3] = {0, 0, 0}, out[3] = {0, 0, 0};
    for (int i = 0; i < m_channels; ++i) {
        double s = 0;
        for (int c = 0; c < m_channels; ++c)
            s += m_basis(c, i) * (v[c] - m_mean[static_cast<std::size_t>(c)]);
        y[i] = lookup(i, s);
    }
    for (int c = 0; c < m_channels; ++c) {
        double s = m_mean[static_cast<std::size_t>(c)];
        for (int i = 0; i < m_channels; ++i) s += m_basis(c, i) * y[i];
        out[c] = s;
    }
    for (int c = 0; c < m_channels; ++c) v[c] = static_cast<float>(out[c]);
}

double MarginalTables::expected(int i) const {
    const auto& rule = check_rule();
    double e = 0;
    for (std::size_t r = 0; r < rule.z.size(); ++r)
        e += rule.w[r] * lookup(i, m_sigma[static_cast<std::size_t>(i)] * rule.z[r]);
    return e;
}

} // namespace textond::core
