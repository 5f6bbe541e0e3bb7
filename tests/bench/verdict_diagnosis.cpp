// Why the phase coherence index called structured textures micro, on textures drawn here: for
// each, its coherence at each box-reduced scale (core/phase_coherence.h), the index (their mean),
// and the shape verdict (core/shape_verdict.h) of the texture and of its random-phase synthesis.
// core/README.md "Micro or macro" has the table this prints.
//   verdict_diagnosis [SIDE]   (default 1024)
#include "core/phase_coherence.h"
#include "core/random.h"
#include "core/shape_verdict.h"
#include "core/spectral_synthesis.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

using namespace textond;

namespace {

core::Image draw(int n, const std::function<float(int, int)>& f) {
    core::Image u(n, n, 1);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) u.at(0, x, y) = f(x, y);
    return u;
}

// Discs of radius r on a square lattice of period p (the spotted print).
float spots(int x, int y, int p, double r) {
    const double dx = x % p - p / 2.0, dy = y % p - p / 2.0;
    return dx * dx + dy * dy < r * r ? 1.0f : 0.0f;
}

struct Drawn {
    std::string name;
    core::Image u;
};

void row(const Drawn& d) {
    const core::PhaseCoherence pc = core::phase_coherence(d.u, 2);
    const core::ShapeVerdict v = core::shape_verdict(d.u, 2);
    const core::Image rpn =
        core::synthesize_from_exemplar(d.u, core::SpectralMethod::rpn, d.u.width, d.u.height, 7, 2);
    const core::ShapeVerdict vr = core::shape_verdict(rpn, 2);
    std::printf("| %s |", d.name.c_str());
    for (const auto& s : pc.scales)
        std::printf(" %+.3f%s |", s.coherence, s.si.mean > 0 ? "" : " (flat)");
    std::printf(" **%+.4f** %s | %+.2f %s | %+.2f %s | %+.3f %+.3f %+.2f %+.2f |\n", pc.index,
                core::to_string(pc.kind()), v.score, core::to_string(v.kind()), vr.score,
                core::to_string(vr.kind()), v.excess.tensor, v.excess.tv, v.excess.lines,
                v.excess.specks);
}

} // namespace

int main(int argc, char** argv) {
    const int n = argc > 1 ? std::atoi(argv[1]) : 1024;
    if (n < 128 || n > 4096) {
        std::fprintf(stderr, "SIDE must be 128..4096\n");
        return 1;
    }
    const int q = n / 32; // a period of 1/32 of the side: 32 px at 1024
    core::Rng rng(3);
    std::vector<Drawn> drawn;
    drawn.push_back({"spots, period " + std::to_string(q) + ", radius " + std::to_string(q / 4),
                     draw(n, [&](int x, int y) { return spots(x, y, q, q / 4.0); })});
    drawn.push_back({"spots, period " + std::to_string(2 * q),
                     draw(n, [&](int x, int y) { return spots(x, y, 2 * q, q / 2.0); })});
    std::vector<std::pair<int, int>> jitter;
    for (int i = 0; i < (n / q) * (n / q); ++i)
        jitter.emplace_back(static_cast<int>(rng.below(q / 2)) - q / 4,
                            static_cast<int>(rng.below(q / 2)) - q / 4);
    drawn.push_back({"spots, jittered", draw(n, [&](int x, int y) {
                         const int cx = x / q, cy = y / q;
                         const auto [jx, jy] = jitter[static_cast<std::size_t>(cy) * (n / q) + cx];
                         const double dx = x - cx * q - q / 2.0 - jx * 0.5;
                         const double dy = y - cy * q - q / 2.0 - jy * 0.5;
                         return dx * dx + dy * dy < q * q / 16.0 ? 1.0f : 0.0f;
                     })});
    drawn.push_back({"checkerboard, square " + std::to_string(q / 2), draw(n, [&](int x, int y) {
                         return ((x / (q / 2) + y / (q / 2)) % 2) ? 1.0f : 0.0f;
                     })});
    drawn.push_back(
        {"bricks " + std::to_string(2 * q) + " x " + std::to_string(q), draw(n, [&](int x, int y) {
             const int course = y / q, shift = (course % 2) * q;
             const bool joint = y % q < q / 8 || (x + shift) % (2 * q) < q / 8;
             return joint ? 0.0f : 1.0f;
         })});
    drawn.push_back({"sparse grain (1% of pixels)",
                     draw(n, [&](int, int) { return rng.uniform() < 0.01 ? 1.0f : 0.0f; })});
    drawn.push_back({"white Gaussian noise",
                     draw(n, [&](int, int) { return static_cast<float>(rng.normal()); })});

    std::printf("Drawn at %d x %d. Phase coherence 1 - TV/E[TV] at each box-reduced scale, the "
                "index (their mean), and the shape verdict of the texture and of its random-phase "
                "synthesis (score: log-odds of macro), and the verdict's statistics.\n\n",
                n, n);
    std::printf("| texture | 128 px | 64 px | 32 px | index | shape verdict | its RPN | excess: "
                "tensor, tv, lines, specks |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const Drawn& d : drawn) row(d);
    return 0;
}
