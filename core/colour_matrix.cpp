#include "core/colour_matrix.h"

#include <algorithm>
#include <cmath>

namespace textond::core {

ColourMatrix multiply(const ColourMatrix& a, const ColourMatrix& b) {
    ColourMatrix c;
    c.n = a.n;
    for (int i = 0; i < a.n; ++i)
        for (int j = 0; j < a.n; ++j) {
            double s = 0.0;
            for (int k = 0; k < a.n; ++k) s += a(i, k) * b(k, j);
            c(i, j) = s;
        }
    return c;
}

ColourMatrix transpose(const ColourMatrix& a) {
    ColourMatrix t;
    t.n = a.n;
    for (int i = 0; i < a.n; ++i)
        for (int j = 0; j < a.n; ++j) t(i, j) = a(j, i);
    return t;
}

double max_abs_difference(const ColourMatrix& a, const ColourMatrix& b) {
    double d = 0.0;
    for (int i = 0; i < a.n; ++i)
        for (int j = 0; j < a.n; ++j) d = std::max(d, std::abs(a(i, j) - b(i, j)));
    return d;
}

double max_abs(const ColourMatrix& a) {
    double d = 0.0;
    for (int i = 0; i < a.n; ++i)
        for (int j = 0; j < a.n; ++j) d = std::max(d, std::abs(a(i, j)));
    return d;
}

void symmetric_eigen(const ColourMatrix& in, ChannelValues& w, ColourMatrix& v) {
    const int n = in.n;
    ColourMatrix a = in;
    v = ColourMatrix{};
    v.n = n;
    for (int i = 0; i < n; ++i) v(i, i) = 1.0;
    for (int sweep = 0; sweep < 64; ++sweep) {
        double off = 0.0;
        for (int p = 0; p < n; ++p)
            for (int q = p + 1; q < n; ++q) off += a(p, q) * a(p, q);
        if (off <= 1e-300) break;
        for (int p = 0; p < n; ++p)
            for (int q = p + 1; q < n; ++q) {
                if (a(p, q) == 0.0) continue;
                // Rotation that zeroes a(p, q) (Golub & Van Loan, Algorithm 8.4.1).
                const double theta = (a(q, q) - a(p, p)) / (2.0 * a(p, q));
                const double t =
                    (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0);
                const double s = t * c;
                for (int k = 0; k < n; ++k) {
                    const double akp = a(k, p), akq = a(k, q);
                    a(k, p) = c * akp - s * akq;
                    a(k, q) = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) {
                    const double apk = a(p, k), aqk = a(q, k);
                    a(p, k) = c * apk - s * aqk;
                    a(q, k) = s * apk + c * aqk;
                }
                for (int k = 0; k < n; ++k) {
                    const double vkp = v(k, p), vkq = v(k, q);
                    v(k, p) = c * vkp - s * vkq;
                    v(k, q) = s * vkp + c * vkq;
                }
            }
    }
    w = {};
    for (int i = 0; i < n; ++i) w[static_cast<std::size_t>(i)] = a(i, i);
}

namespace {
template <class F> ColourMatrix spectral_map(const ColourMatrix& a, F f) {
    ChannelValues w{};
    ColourMatrix v;
    symmetric_eigen(a, w, v);
    double wmax = 0.0;
    for (int i = 0; i < a.n; ++i) wmax = std::max(wmax, w[static_cast<std::size_t>(i)]);
    ColourMatrix r;
    r.n = a.n;
    for (int i = 0; i < a.n; ++i)
        for (int j = 0; j < a.n; ++j) {
            double s = 0.0;
            for (int k = 0; k < a.n; ++k)
                s += v(i, k) * f(w[static_cast<std::size_t>(k)], wmax) * v(j, k);
            r(i, j) = s;
        }
    return r;
}
} // namespace

ColourMatrix sqrt_psd(const ColourMatrix& a) {
    return spectral_map(a, [](double w, double) { return w > 0.0 ? std::sqrt(w) : 0.0; });
}

ColourMatrix pinv_sqrt_psd(const ColourMatrix& a, double rel_tol) {
    return spectral_map(a, [rel_tol](double w, double wmax) {
        return (w > rel_tol * wmax && w > 0.0) ? 1.0 / std::sqrt(w) : 0.0;
    });
}

} // namespace textond::core
