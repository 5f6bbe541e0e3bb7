#include "core/random.h"

#include <cmath>
#include <stdexcept>

namespace textond::core {

namespace {
constexpr std::uint64_t rotl(std::uint64_t x, int k) {
    return (x << k) | (x >> (64 - k));
}
constexpr double kTwoPi = 6.283185307179586476925286766559;
// Inversion is exact and costs O(mean); 64 keeps exp(-mean) far from underflow.
constexpr double kPoissonChunk = 64.0;
} // namespace

Rng::Rng(std::uint64_t seed, std::uint64_t stream) {
    std::uint64_t st = seed ^ (stream * 0xD1342543DE82EF95ull);
    for (auto& s : m_s) s = splitmix64(st);
}

std::uint64_t Rng::next_u64() {
    const std::uint64_t result = rotl(m_s[1] * 5, 7) * 9;
    const std::uint64_t t = m_s[1] << 17;
    m_s[2] ^= m_s[0];
    m_s[3] ^= m_s[1];
    m_s[1] ^= m_s[2];
    m_s[0] ^= m_s[3];
    m_s[2] ^= t;
    m_s[3] = rotl(m_s[3], 45);
    return result;
}

double Rng::uniform() {
    return static_cast<double>(next_u64() >> 11) * 0x1.0p-53;
}

double Rng::uniform_open() {
    return (static_cast<double>(next_u64() >> 11) + 0.5) * 0x1.0p-53;
}

std::uint64_t Rng::below(std::uint64_t n) {
    if (n == 0) throw std::invalid_argument("Rng::below(0)");
    // Lemire's rejection keeps the draw unbiased for any n.
    const std::uint64_t threshold = (0 - n) % n;
    for (;;) {
        const std::uint64_t r = next_u64();
        if (r >= threshold) return r % n;
    }
}

double Rng::normal() {
    if (m_has_spare) {
        m_has_spare = false;
        return m_spare;
    }
    const double radius = std::sqrt(-2.0 * std::log(uniform_open()));
    const double angle = kTwoPi * uniform();
    m_spare = radius * std::sin(angle);
    m_has_spare = true;
    return radius * std::cos(angle);
}

std::uint64_t Rng::poisson(double mean) {
    if (!(mean >= 0.0) || !std::isfinite(mean)) throw std::invalid_argument("poisson: bad mean");
    std::uint64_t total = 0;
    // A sum of independent Poisson variables is Poisson with the summed mean: exact for any mean.
    while (mean > 0.0) {
        const double m = mean > kPoissonChunk ? kPoissonChunk : mean;
        mean -= m;
        double p = std::exp(-m);
        double cdf = p;
        const double u = uniform();
        std::uint64_t k = 0;
        while (u >= cdf) {
            ++k;
            p *= m / static_cast<double>(k);
            const double next = cdf + p;
            if (next == cdf) break; // tail below double resolution
            cdf = next;
        }
        total += k;
    }
    return total;
}

} // namespace textond::core
