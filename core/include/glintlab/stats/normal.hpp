// Standard normal functions shared by the Gaussian-based laws, templated on the arithmetic type.
#pragma once

#include <boost/math/special_functions/erf.hpp>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace glintlab::normal {

namespace detail {
// Horner evaluation of c[0] + c[1] x + ... + c[7] x^7.
template <class T>
inline T poly7(const double (&c)[8], T x) {
  T s = T(c[7]);
  for (int i = 6; i >= 0; --i) s = s * x + T(c[i]);
  return s;
}
// Wichura (1988), Algorithm AS 241 (PPND16), Applied Statistics 37(3): rational approximations of
// Phi^-1 with relative error ~1e-16 in three regions: |u - 1/2| <= 0.425, then r = sqrt(-log(min(u,
// 1 - u))) <= 5 and beyond. Coefficients as published.
inline constexpr double kA[8] = {3.3871328727963666080e0,  1.3314166789178437745e+2, 1.9715909503065514427e+3,
                                 1.3731693765509461125e+4, 4.5921953931549871457e+4, 6.7265770927008700853e+4,
                                 3.3430575583588128105e+4, 2.5090809287301226727e+3};
inline constexpr double kB[8] = {1.0,
                                 4.2313330701600911252e+1,
                                 6.8718700749205790830e+2,
                                 5.3941960214247511077e+3,
                                 2.1213794301586595867e+4,
                                 3.9307895800092710610e+4,
                                 2.8729085735721942674e+4,
                                 5.2264952788528545610e+3};
inline constexpr double kC[8] = {1.42343711074968357734e0,  4.63033784615654529590e0, 5.76949722146069140550e0,
                                 3.64784832476320460504e0,  1.27045825245236838258e0, 2.41780725177450611770e-1,
                                 2.27238449892691845833e-2, 7.74545014278341407640e-4};
inline constexpr double kD[8] = {1.0,
                                 2.05319162663775882187e0,
                                 1.67638483018380384940e0,
                                 6.89767334985100004550e-1,
                                 1.48103976427480074590e-1,
                                 1.51986665636164571966e-2,
                                 5.47593808499534494600e-4,
                                 1.05075007164441684324e-9};
inline constexpr double kE[8] = {6.65790464350110377720e0,  5.46378491116411436990e0,  1.78482653991729133580e0,
                                 2.96560571828504891230e-1, 2.65321895265761230930e-2, 1.24266094738807843860e-3,
                                 2.71155556874348757815e-5, 2.01033439929228813265e-7};
inline constexpr double kF[8] = {1.0,
                                 5.99832206555887937690e-1,
                                 1.36929880922735805310e-1,
                                 1.48753612908506148525e-2,
                                 7.86869131145613259100e-4,
                                 1.84631831751005468180e-5,
                                 1.42151175831644588870e-7,
                                 2.04426310338993978564e-15};
}  // namespace detail

// Phi^-1(u) for u in [0, 1] (-inf at 0, +inf at 1), by AS 241 evaluated in T: about 10x cheaper than
// Boost's erfc_inv (the laws' hot path), within a few eps of it in double (tests compare the two).
template <class T>
T quantile(T u) {
  if (u <= T(0)) return -std::numeric_limits<T>::infinity();
  if (u >= T(1)) return std::numeric_limits<T>::infinity();
  const T q = u - T(0.5);
  if (std::abs(q) <= T(0.425)) {
    const T r = T(0.180625) - q * q;
    return q * detail::poly7(detail::kA, r) / detail::poly7(detail::kB, r);
  }
  T r = std::sqrt(-std::log(q < T(0) ? u : T(1) - u));
  T x;
  if (r <= T(5)) {
    r -= T(1.6);
    x = detail::poly7(detail::kC, r) / detail::poly7(detail::kD, r);
  } else {
    r -= T(5);
    x = detail::poly7(detail::kE, r) / detail::poly7(detail::kF, r);
  }
  return q < T(0) ? -x : x;
}

// quantile(u) for u in (0, 1) with log(min(u, 1 - u)) given by the caller (log_tail: a vector log,
// possibly an ulp away from std::log). In the central region |u - 1/2| <= 0.425 it is quantile(u)
// bit for bit (the same expressions, log_tail unused) and `central` is set; outside it differs from
// quantile(u) only through log_tail, by a few ulps: callers guard their decisions there.
inline double quantile_given_log(double u, double log_tail, bool& central) {
  const double q = u - 0.5;
  central = std::abs(q) <= 0.425;
  if (central) {
    const double r = 0.180625 - q * q;
    return q * detail::poly7(detail::kA, r) / detail::poly7(detail::kB, r);
  }
  double r = std::sqrt(-log_tail);
  double x;
  if (r <= 5.0) {
    r -= 1.6;
    x = detail::poly7(detail::kC, r) / detail::poly7(detail::kD, r);
  } else {
    r -= 5.0;
    x = detail::poly7(detail::kE, r) / detail::poly7(detail::kF, r);
  }
  return q < 0.0 ? -x : x;
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
LatticeLaw discretized(double mean, double sd, double top, double shift, std::size_t max_support, const char* where);

}  // namespace glintlab::normal
