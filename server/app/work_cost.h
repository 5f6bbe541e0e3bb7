#pragma once
// What a request's work may cost, in estimated single-core CPU seconds: requests over the budget
// (--max-request-cpu-s) are refused (413) before they start, and the rest wait for a slot
// (slots.h), so that memory and CPU grow with the slots and not with the clients.
#include <cstddef>
#include <cstdint>

namespace textond::app {

// Estimated single-core CPU seconds, from per-unit costs measured with `textond bench render`
// on the CI machine (order 1, r 64): a kernel tap 1.5 ns, a (surface point, tap) 55 ns, a
// rasteriser pixel test 10 ns. Coarse on purpose: they only have to rank requests against the
// budget (--max-request-cpu-s; deploy/README.md "Hostile clients").
int taps_of_order(int order); // 1, 4 or 16
double noise_work_s(std::int64_t pixels, double mni, int order);
// What an exact zoomed-out level (0 < level < core::noise::limit_level(size)) adds: it lists every
// point that reaches a w x h window, (w 2^level + size) (h 2^level + size) mni / size^2 of them, at
// 240 ns of one core each, the most a point cost among the fit half of `textond render`'s
// measurements (single thread, 512 x 512, CPU time beyond level 0's): textons of size 64 at
// levels 3 to 5, MNI 30 and 200 (116-237 ns). On the other half, sizes 16 and 256 at levels 2 to
// 7 (81-367 ns), the measured CPU is 0.34-1.53x the estimate; without the term a level-7 tile of
// a texton of 256 at MNI 200 took 12-18x its estimate (deploy/README.md "Hostile clients").
// 0 for level 0, magnified levels and the limit model's levels, whose cost does not grow so.
double zoomed_points_work_s(std::int64_t w, std::int64_t h, int level, double mni, int size);
double surface_work_s(std::size_t points, double mni, int order);
double mesh_work_s(std::uint64_t raster_tests, std::int64_t pixels, double mni, int order);
// An analysis (core/texton_analysis.h) works on its window (at most 1024 x 1024 and of fast FFT
// sizes, core::window_size for texton support `size`): 4.37 ns of one core a window
// channel-pixel and iteration (the alternating projections, texton paper section 4), 54 ns a
// window channel-pixel (periodic component, model, RME, marginals), 180 ns a window pixel (the
// grey shape verdict and phase coherence), all times 1 + (e(w) + e(h)) / 2 where a side with a
// factor 5 adds 0.45 and one with a factor 7 1.00 (FFTW's time a pixel), plus 45 ms an analysis
// and 10 ns a channel-pixel of the whole exemplar for its id (sha256 of its floats) and the
// window's copy. Form chosen (worst fit-half ratio 1.21, against 2.03 for the form before,
// linear in iterations + 8) and constants fitted on one half of the shared photos, at their own
// sizes and made 1024², 1000² and 1008², 20 and 200 iterations, by tests/bench/analysis_cost.py;
// on the other half the measured CPU is 0.84-1.24x the estimate. The upload is refused (413
// work_too_large) before it is queued when over --max-request-cpu-s.
double analysis_work_s(int width, int height, int channels, int iterations, int size);
// What a side with a factor 5 or 7 costs an FFT of width x height against a power of two's
// (1 + (e(width) + e(height)) / 2, e = 0.45 for a 5 and 1.00 for a 7), as analysis_cost.py
// fitted it for analyses; mixes take it as it is.
double fft_sides_factor(int width, int height);
// A texture mix (core/texture_mix.h) runs `levels` analyses from a model over the common grid
// (core::mix_grid: the two exemplars' smaller width and height, at most 1024, at fast FFT sizes;
// the more channels): kMixNs of one core a grid channel-pixel, level and iteration, with
// kMixFixedIterations' worth of fixed work a level, times log2(grid pixels) / 16 (an FFT's cost a
// pixel grows with the log of its size: 1 at 256 x 256, 1.25 at 1024 x 1024). Form and constants
// chosen and fitted on one half of the shared photos' pairs, at their own sizes and made
// 1024 x 1024, by tests/bench/mix_cost.py; on the other half the measured CPU is 0.96-1.44x the
// estimate, a grey pair's the most above it. Times fft_sides_factor of the grid, taken from the
// analyses' fit and not refitted: without it a 1008 x 1008 grid took 1.9-2.2x the estimate and
// 1000 x 1000 1.4-1.7x, with it 0.94-1.18x (pave + pebbles and brick + grass made 1008², 1000²,
// 4 levels, 20 iterations, one thread; 1024²: 1.07 and 1.39).
double mix_work_s(int width, int height, int channels, int iterations, int levels);

} // namespace textond::app
