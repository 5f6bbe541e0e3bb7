#pragma once
// Timing work on a GPU at the clock it serves at. A GPU raises its clock only under sustained
// load: the first rounds of a short measurement run at its idle clock (render/BENCHMARKS.md:
// 345-660 MHz of 1980 on an H100, where the tiles measured 13x slower than the same GPU served
// them). So `f` is repeated until it has run for `least_ms` and kSettled rounds in a row have not
// beaten the best by 5%, or for `most_ms`; the best round counts. A CPU settles in the first
// rounds. Used by auto's calibration (backend_factory.cpp) and bench render's GPU frames.
#include "core/result.h"

#include <algorithm>
#include <chrono>
#include <optional>

namespace textond::render {

constexpr int kSettled = 3;

struct Settled {
    double ms = 0;
    int rounds = 0;
};

// `f` returns std::optional<Error>: an error ends the measurement.
template <class F> Result<Settled> settled_ms(double least_ms, double most_ms, F&& f) {
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    Settled out;
    for (int since_best = 0;;) {
        const auto t0 = clock::now();
        if (auto e = f()) return *e;
        const auto t1 = clock::now();
        const double ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
        const double spent = std::chrono::duration<double, std::milli>(t1 - start).count();
        since_best = out.rounds == 0 || ms < 0.95 * out.ms ? 0 : since_best + 1;
        out.ms = out.rounds == 0 ? ms : std::min(out.ms, ms);
        ++out.rounds;
        if (spent >= most_ms || (spent >= least_ms && since_best >= kSettled)) return out;
    }
}

} // namespace textond::render
