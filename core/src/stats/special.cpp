#include "glintlab/stats/special.hpp"

#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>

namespace glintlab::special {

namespace {
constexpr double kLnSqrt2Pi = 0.918938533204672741780329736406;  // log(sqrt(2 pi))
constexpr double kLn2Pi = 1.837877066409345483560659472811;
}  // namespace

namespace {
// stirlerr at 0.5, 1, ..., 15, computed once from Boost's lgamma in long double: the samplers' final
// acceptance tests hit small integer k constantly, and lgamma costs ~100 ns a call.
struct StirlerrTable {
  double v[31];
  StirlerrTable() {
    v[0] = 0.0;
    for (int i = 1; i <= 30; ++i) {
      const long double x = 0.5L * i;
      v[i] = static_cast<double>(boost::math::lgamma(x + 1.0L) - (x + 0.5L) * std::log(x) + x -
                                 0.918938533204672741780329736406L);
    }
  }
};
const StirlerrTable kStirlerrTable;
}  // namespace

double stirlerr(double x) {
  // Asymptotic series 1/(12x) - 1/(360x^3) + 1/(1260x^5) - 1/(1680x^7) + 1/(1188x^9); the number of
  // terms needed for full double precision falls as x grows (Loader's cut points).
  constexpr double s0 = 1.0 / 12, s1 = 1.0 / 360, s2 = 1.0 / 1260, s3 = 1.0 / 1680, s4 = 1.0 / 1188;
  if (x <= 15.0) {
    if (x == 0.0) return 0.0;  // only reached for k = 0 or k = n, where the caller's formula is exact
    const double twice = 2.0 * x;
    if (twice == std::floor(twice)) return kStirlerrTable.v[static_cast<int>(twice)];
    // Small x: no cancellation worth the name (all terms are O(10)); Boost's lgamma is thread-safe,
    // unlike std::lgamma which writes the global signgam.
    return boost::math::lgamma(x + 1.0) - (x + 0.5) * std::log(x) + x - kLnSqrt2Pi;
  }
  const double x2 = x * x;
  if (x > 500) return (s0 - s1 / x2) / x;
  if (x > 80) return (s0 - (s1 - s2 / x2) / x2) / x;
  if (x > 35) return (s0 - (s1 - (s2 - s3 / x2) / x2) / x2) / x;
  return (s0 - (s1 - (s2 - (s3 - s4 / x2) / x2) / x2) / x2) / x;
}

double bd0(double x, double m, double x_minus_m) {
  if (x == 0.0) return m;
  if (std::abs(x_minus_m) < 0.1 * (x + m)) {
    // x log(x/M) + M - x = (x - M) v + 2x sum_{j>=1} v^(2j+1)/(2j+1), v = (x - M)/(x + M), |v| < 0.1.
    const double v = x_minus_m / (x + m);
    double s = x_minus_m * v;
    double ej = 2.0 * x * v;
    const double v2 = v * v;
    for (int j = 1; j < 1000; ++j) {
      ej *= v2;
      const double s1 = s + ej / (2 * j + 1);
      if (s1 == s) return s1;
      s = s1;
    }
    return s;
  }
  // Far from the mode: the direct form has no cancellation. x/M may overflow for M ~ 1e-300; the
  // log then is +inf and the pmf underflows to 0, which is the right answer.
  return x * std::log(x / m) + m - x;
}

double binomial_log_pmf_int(double k, double n, double p) {
  constexpr double ninf = -std::numeric_limits<double>::infinity();
  if (k < 0 || k > n) return ninf;
  if (p == 0.0) return k == 0 ? 0.0 : ninf;
  if (p == 1.0) return k == n ? 0.0 : ninf;
  // Work with the smaller probability: for p > 1/2, 1 - p is exact (Sterbenz), while n (1 - p)
  // formed from a rounded n p would carry an absolute error ~ n p eps (0.06 at n = 1e15), which
  // the deviance of the n - k side turns into a 1e-5 error of the log pmf.
  if (p > 0.5) return binomial_log_pmf_int(n - k, n, 1.0 - p);
  if (k == 0) return n * std::log1p(-p);  // (1-p)^n through log1p: exact even for p = 1e-300
  if (k == n) return n * std::log(p);
  const double q = 1.0 - p;
  const double np = n * p, nq = n * q;
  const double d = k_minus_np(k, n, p);  // k - n p without the rounding of n p
  const double lc = stirlerr(n) - stirlerr(k) - stirlerr(n - k) - bd0(k, np, d) - bd0(n - k, nq, -d);
  // log(2 pi k (n - k) / n) with (n - k)/n = 1 - k/n via log1p.
  const double lf = kLn2Pi + std::log(k) + std::log1p(-k / n);
  return lc - 0.5 * lf;
}

BinomialLogRatio::BinomialLogRatio(double n, double p, double j, bool precompute)
    : n_(n), p_(p), j_(j), np_hi_(n * p), nq_(n * (1.0 - p)), precomputed_(precompute) {
  if (precompute) {
    np_lo_ = std::fma(n, p, -np_hi_);
    at_j_ = term(j, np_lo_);
  }
}

double BinomialLogRatio::term(double k, double np_lo) const {
  const double d = (k - np_hi_) - np_lo;
  return -stirlerr(k) - stirlerr(n_ - k) - bd0(k, np_hi_, d) - bd0(n_ - k, nq_, -d) -
         0.5 * (std::log(k) + std::log1p(-k / n_));
}

double BinomialLogRatio::operator()(double k) const {
  if (precomputed_) return term(k, np_lo_) - at_j_;
  const double np_lo = std::fma(n_, p_, -np_hi_);
  return term(k, np_lo) - term(j_, np_lo);
}

double poisson_log_pmf(double k, double lambda) {
  constexpr double ninf = -std::numeric_limits<double>::infinity();
  if (k < 0) return ninf;
  if (lambda == 0.0) return k == 0 ? 0.0 : ninf;
  if (k == 0) return -lambda;
  return -stirlerr(k) - bd0(k, lambda) - 0.5 * (kLn2Pi + std::log(k));
}

}  // namespace glintlab::special
