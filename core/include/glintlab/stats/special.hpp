// Saddle-point pieces of Loader (2000), "Fast and accurate computation of binomial probabilities":
// log pmfs written as sums of small, well-conditioned terms instead of differences of lgamma values.
// With n = 1e15, lgamma(n + 1) ~ 3.4e16 and its rounding error alone (~4) would swamp the log-pmf;
// the saddle-point form keeps relative accuracy near 1e-13 for every n.
#pragma once

#include <cmath>

namespace glintlab::special {

// stirlerr(x) = log(x!) - [(x + 1/2) log x - x + log sqrt(2 pi)]: the error of Stirling's formula.
double stirlerr(double x);

// bd0(x, M) = x log(x / M) + M - x >= 0, the deviance term, computed without cancellation when x ~ M.
// `x_minus_m` must be x - M computed as accurately as the caller can (e.g. n p - k rather than
// (n - k) - n (1 - p)).
double bd0(double x, double m, double x_minus_m);
inline double bd0(double x, double m) { return bd0(x, m, x - m); }

// x - n p computed without the rounding error of the product n p (an error-free FMA split): at
// n = 1e15 the product alone is off by up to 0.06, comparable to what the deviance terms resolve.
inline double k_minus_np(double x, double n, double p) {
  const double np = n * p;
  const double np_lo = std::fma(n, p, -np);  // n p = np + np_lo exactly
  return (x - np) - np_lo;
}

// log P(K = k) for K ~ Binomial(n, p), integer-valued n >= 0 and k in [0, n].
double binomial_log_pmf_int(double k, double n, double p);
// log P(K = k) - log P(K = j) for Binomial(n, p), p <= 1/2, 0 < j, k < n, with n p split as
// np_hi + np_lo exactly: the samplers' acceptance test, which must not pay for std::fma (a
// software routine without -mfma) nor for the terms of the fixed point j on every call.
// `precompute` = false defers all setup to each call (for one-off samplers, which rarely reach the
// acceptance test at all).
struct BinomialLogRatio {
  BinomialLogRatio() = default;
  BinomialLogRatio(double n, double p, double j, bool precompute);
  double operator()(double k) const;  // log f(k) - log f(j)

 private:
  double term(double k, double np_lo) const;  // log f(k) + stirlerr(n) (the part that depends on k)
  double n_ = 0, p_ = 0, j_ = 0, np_hi_ = 0, np_lo_ = 0, nq_ = 0, at_j_ = 0;
  bool precomputed_ = false;
};

// log P(K = k) for K ~ Poisson(lambda), integer k >= 0.
double poisson_log_pmf(double k, double lambda);

}  // namespace glintlab::special

namespace glintlab::special {

// Tail masses of Binomial(n, p) (integer n) and Poisson(lambda), each returned directly (never as
// 1 - the other), so rare-glint probabilities keep full relative precision.
//
// Method, by the variance v of the law:
//  - v <= kTailSumVariance: summation of the pmf from k away from the mode (the smaller side),
//    started from the saddle-point pmf and continued by the exact ratio recurrence, stopped when
//    a geometric bound on the rest is below 1e-17 of the sum. At most ~ 9 sd + 40 terms; the
//    recurrence's rounding drift is below (terms) x eps ~ 1e-12 relative.
//  - v > kTailSumVariance: the Lugannani-Rice saddle-point formula with Daniels' (1987) second
//    continuity correction for lattice laws, whose relative error falls like v^(-3/2) (measured
//    2e-10 at v = 1e6 nine standard deviations out, below 1e-10 from v = 1e7 up; tests compare it
//    with summation). Boost's incomplete beta and
//    gamma are not used there: at n = 1e12 they are off by 1e-5 (pdf) or give up (gamma_q).
inline constexpr double kTailSumVariance = 1e7;

double binomial_lower_tail(double k, double n, double p);  // P(K <= k)
double binomial_upper_tail(double k, double n, double p);  // P(K > k)
double poisson_lower_tail(double k, double lambda);
double poisson_upper_tail(double k, double lambda);

// The same, forcing one method (for tests that compare the two).
double binomial_upper_tail_sum(double k, double n, double p);
double binomial_upper_tail_saddle(double k, double n, double p);
double poisson_upper_tail_sum(double k, double lambda);
double poisson_upper_tail_saddle(double k, double lambda);

}  // namespace glintlab::special
