// Standard normal functions shared by the Gaussian-based laws, templated on the arithmetic type.
#pragma once

#include <boost/math/special_functions/erf.hpp>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace glintlab::normal {

// Phi^-1(u) for u in [0, 1] (-inf at 0, +inf at 1), as -sqrt(2) erfc^-1(2u): accurate in both tails.
template <class T>
T quantile(T u) {
  if (u <= T(0)) return -std::numeric_limits<T>::infinity();
  if (u >= T(1)) return std::numeric_limits<T>::infinity();
  return -T(1.41421356237309504880) * boost::math::erfc_inv(T(2) * u);
}

// P(Z <= x) and P(Z > x), each from erfc so that both tails keep relative precision.
inline double cdf(double x) { return 0.5 * boost::math::erfc(-x / 1.41421356237309504880); }
inline double sf(double x) { return 0.5 * boost::math::erfc(x / 1.41421356237309504880); }

// P(a < Z <= b) without cancellation in either tail.
inline double interval(double a, double b) {
  if (!(b > a)) return 0.0;
  if (a >= 0) return sf(a) - sf(b);
  if (b <= 0) return cdf(b) - cdf(a);
  return 1.0 - cdf(a) - sf(b);
}

// The exact law of K = clamp(floor(mean + sd Z + shift), 0, top) (shift 0: floor, 1/2: round),
// on the counts within 8.5 sd of the mean (the rest, < 1e-16 a side, trimmed and flagged).
// sd must be > 0. Throws std::invalid_argument naming `where` beyond max_support points.
struct LatticeLaw {
  std::vector<double> support, probs;
  bool trimmed_below = false, trimmed_above = false;
};
LatticeLaw discretized(double mean, double sd, double top, double shift, std::size_t max_support,
                       const char* where);

}  // namespace glintlab::normal
