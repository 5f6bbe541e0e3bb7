#pragma once
// The part of a large exemplar an analysis looks at. The model is the exemplar's periodic
// autocorrelation (SOT paper, section 3.1), whose DFT is the periodogram |t_u^|^2: a single,
// unsmoothed estimate at every size, so more pixels resolve finer spectral detail but not a
// less noisy one, and an r x r texton (r <= 256) holds neither. Past kWorkingSide pixels a side
// the centred window of that size stands for the exemplar: the analysis of a 4096 x 4096 exemplar
// costs what a 1024 x 1024 one does, and its RME moves by less than 0.01 (README, "Analysis
// time", measured by `textond bench analyze`).
#include "core/image.h"

namespace textond::core {

inline constexpr int kWorkingSide = 1024;

// Whether an exemplar of this size is analysed through a window (`side` 0: never).
bool is_windowed(int width, int height, int side = kWorkingSide);

// The centred w x h part of u (w <= u.width, h <= u.height).
Image centred_part(const Image& u, int w, int h);

// The centred window of at most `side` x `side` pixels; empty when u fits (or `side` is 0), so
// that callers use u itself without a copy.
Image working_window(const Image& u, int side = kWorkingSide);

} // namespace textond::core
