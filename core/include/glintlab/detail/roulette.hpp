// The mollified roulette's moments (core/blends/roulette.cpp; docs/math/blends.md, "roulette"):
// internal to the library and its tests.
#pragma once

#include <array>

namespace glintlab::blend_detail {

// E[R(r, weight)] and E[R(r, weight)^2] for r ~ U(0, 1) by Gauss-Kronrod quadrature (31 points)
// between R's breakpoints: the reference the closed form blend_detail::roulette_moments is tested
// against (about 300 evaluations of R; not used for sampling).
std::array<double, 2> roulette_moments_quadrature(double weight, double eps);

// The closed form's three pieces for weight in (0, 1), eps in (0, 1/2]: {E, E2} over r in [0, eps],
// [eps, 1 - eps] and [1 - eps, 1] (roulette_moments sums them; tests drop one to show that their
// comparison with the quadrature catches a missing piece).
std::array<std::array<double, 2>, 3> roulette_moment_pieces(double weight, double eps);

}  // namespace glintlab::blend_detail
