#pragma once
// The part of a large exemplar an analysis looks at. The model is the exemplar's periodic
// autocorrelation (SOT paper, section 3.1), whose DFT is the periodogram |t_u^|^2: a single,
// unsmoothed estimate at every size, so more pixels resolve finer spectral detail but not a
// less noisy one, and an r x r texton (r <= 256) holds neither. Past kWorkingSide pixels a side
// the centred window of that size stands for the exemplar: the analysis of a 4096 x 4096 exemplar
// costs what a 1024 x 1024 one does, and its RME moves by less than 0.01 (README, "Analysis
// time", measured by `textond bench analyze`).
//
// A side with a prime factor over 7 is also brought down to the next size FFTW has codelets for
// (fast_fft_size): every step transforms the window, and an analysis of a 1019 x 1019 exemplar (a
// prime side) cost 5x what one of 1024 x 1024 does (core/README.md, "FFT sizes"). The
// crop loses a few rows or columns; a seamless tile of such a size loses its seamlessness.
#include "core/image.h"

#include <array>

namespace textond::core {

inline constexpr int kWorkingSide = 1024;

// The largest m <= n that is_fft_friendly (core/fft2d.h: 2^a 3^b 5^c 7^d; n itself for n <= 1).
int fast_fft_size(int n);
// fast_fft_size(n), unless that is under `least` (an analysis' 2r): then n.
int fast_side(int n, int least);

// The sides of the window an analysis of a width x height exemplar looks at: each min(n, side)
// brought down to fast_fft_size, unless that is under `least` (the analysis' 2r: it is then left
// as it is). `side` 0: the whole exemplar, as it is (benchmarks).
std::array<int, 2> window_size(int width, int height, int side = kWorkingSide, int least = 0);

// Whether an exemplar of this size is cut to kWorkingSide (`side` 0: never). Only that cut
// names the texton differently (server/io/texton_file.cpp); the FFT crop adds its own name.
bool is_windowed(int width, int height, int side = kWorkingSide);

// The centred w x h part of u (w <= u.width, h <= u.height).
Image centred_part(const Image& u, int w, int h);

// The centred window of window_size; empty when that is u itself, so that callers use u without
// a copy.
Image working_window(const Image& u, int side = kWorkingSide, int least = 0);

} // namespace textond::core
