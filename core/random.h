#pragma once
// Seeded, platform-independent random numbers for the analysis and the reference syntheses.
// std:: distributions are implementation-defined, so every draw here is written out.
#include <cstdint>

namespace textond::core {

constexpr std::uint64_t splitmix64(std::uint64_t& state) {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// xoshiro256** (Blackman & Vigna), seeded through splitmix64 from (seed, stream).
class Rng {
public:
    explicit Rng(std::uint64_t seed, std::uint64_t stream = 0);
    std::uint64_t next_u64();
    double uniform();                     // [0, 1), 53 bits
    double uniform_open();                // (0, 1), never 0: safe under log()
    std::uint64_t below(std::uint64_t n); // uniform in [0, n), unbiased
    double normal();                      // standard normal, Box-Muller
    std::uint64_t poisson(double mean);   // exact (inversion, split into chunks for large means)

private:
    std::uint64_t m_s[4];
    double m_spare = 0.0;
    bool m_has_spare = false;
};

} // namespace textond::core
