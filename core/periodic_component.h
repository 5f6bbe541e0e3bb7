#pragma once
#include "core/image.h"

namespace textond::core {

// Periodic component p of u (Moisan 2011; RPN paper, section 5.2, eq. (3)): the solution of
// Lap p = Lap_interior u with mean p = mean u, solved in the Fourier domain. It removes the
// border discontinuity that would otherwise put a cross in every spectrum.
Image periodic_component(const Image& u, int threads = 1);

// The two discrete Laplacians of that equation, exposed so tests can check it holds.
Image periodic_laplacian(const Image& u); // 4 u(x) - sum of the 4 periodic neighbours
Image interior_laplacian(const Image& u); // |N_x in Omega| u(x) - sum of neighbours in Omega

} // namespace textond::core
