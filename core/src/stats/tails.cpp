#include <boost/math/special_functions/erf.hpp>
#include <cmath>

#include "glintlab/stats/special.hpp"

namespace glintlab::special {

namespace {

constexpr double kSqrt2 = 1.41421356237309504880;
constexpr double kInvSqrt2Pi = 0.39894228040143267794;

// Sum f(j) for j = k, k + dir, ... (dir = +-1, moving away from the mode of a log-concave law, so
// the ratios f(j + dir)/f(j) = ratio(j) only decrease): stops when the remaining mass, at most
// f / (1 - r), is below 1e-17 of the sum, or at `end`.
template <class Ratio>
double sum_away_from_mode(double k, double fk, int dir, double end, Ratio ratio) {
  double sum = 0.0, f = fk, j = k;
  for (;;) {
    sum += f;
    if (j == end || f == 0.0) return sum;
    const double r = ratio(j);
    f *= r;
    j += dir;
    if (r < 1.0 && f <= 1e-17 * sum * (1.0 - r)) return sum;
  }
}

double normal_upper(double w) { return 0.5 * boost::math::erfc(w / kSqrt2); }

// Lugannani-Rice with Daniels' second continuity correction, for P(K >= x + 1/2) where x is
// the corrected lattice point: returns {P(K >= k), P(K < k)} computed separately.
// `wu(x)` returns (w, u) for the corrected point x. Near the mean both 1/u and 1/w blow up and their
// difference cancels; there the correction term is interpolated linearly between x0 -+ delta
// (delta = 1e-4 sd: interpolation error ~ 1e-8 of a term that is itself ~ 1/sd).
template <class WU>
void lugannani_rice(double x, double mean, double sd, WU wu, double& upper, double& lower) {
  const double delta = 1e-4 * sd;
  auto correction = [&](double xx) {
    const auto [w, u] = wu(xx);
    return 1.0 / u - 1.0 / w;
  };
  double w, c;
  if (std::abs(x - mean) < delta) {
    w = wu(x).first;
    const double ca = correction(mean - delta), cb = correction(mean + delta);
    c = ca + (cb - ca) * (x - (mean - delta)) / (2 * delta);
  } else {
    const auto [ww, u] = wu(x);
    w = ww;
    c = 1.0 / u - 1.0 / w;
  }
  const double phi = kInvSqrt2Pi * std::exp(-0.5 * w * w);
  upper = normal_upper(w) + phi * c;
  lower = normal_upper(-w) - phi * c;
  upper = std::fmax(upper, 0.0);
  lower = std::fmax(lower, 0.0);
}

void binomial_saddle(double k, double n, double p, double& ge, double& lt) {
  // K(s) = n log(q + p e^s); at the saddle point of x = k - 1/2:
  // w^2 = 2 [bd0(x, np) + bd0(n - x, nq)], s = log(x q / ((n - x) p)), u = 2 sinh(s/2) sqrt(x (n - x)/n).
  const double q = 1.0 - p, np = n * p, nq = n * q;
  auto wu = [&](double x) {
    const double d = k_minus_np(x, n, p);
    const double dev = 2.0 * (bd0(x, np, d) + bd0(n - x, nq, -d));
    const double s = std::log1p(d / np) - std::log1p(-d / nq);
    const double w = std::copysign(std::sqrt(std::fmax(dev, 0.0)), s);
    const double u = 2.0 * std::sinh(0.5 * s) * std::sqrt(x * (n - x) / n);
    return std::pair{w, u};
  };
  lugannani_rice(k - 0.5, np, std::sqrt(np * q), wu, ge, lt);
}

void poisson_saddle(double k, double lambda, double& ge, double& lt) {
  // K(s) = lambda (e^s - 1): w^2 = 2 bd0(x, lambda), s = log(x / lambda), u = 2 sinh(s/2) sqrt(x).
  auto wu = [&](double x) {
    const double d = x - lambda;
    const double s = std::log1p(d / lambda);
    const double w = std::copysign(std::sqrt(std::fmax(2.0 * bd0(x, lambda, d), 0.0)), s);
    return std::pair{w, 2.0 * std::sinh(0.5 * s) * std::sqrt(x)};
  };
  lugannani_rice(k - 0.5, lambda, std::sqrt(lambda), wu, ge, lt);
}

// Binomial tails for integer n, 0 < p < 1, 0 <= k < n, by summation.
void binomial_sum(double k, double n, double p, double& lower, double& upper) {
  const double q = 1.0 - p, mode = std::floor((n + 1) * p);
  if (k < mode) {  // P(K <= k): from k down to 0
    lower = sum_away_from_mode(k, std::exp(binomial_log_pmf_int(k, n, p)), -1, 0.0,
                               [&](double j) { return j * q / ((n - j + 1) * p); });
    upper = 1.0 - lower;
  } else {  // P(K > k): from k + 1 up to n
    upper = sum_away_from_mode(k + 1, std::exp(binomial_log_pmf_int(k + 1, n, p)), +1, n,
                               [&](double j) { return (n - j) * p / ((j + 1) * q); });
    lower = 1.0 - upper;
  }
}

void poisson_sum(double k, double lambda, double& lower, double& upper) {
  const double mode = std::floor(lambda);
  if (k < mode) {
    lower = sum_away_from_mode(k, std::exp(poisson_log_pmf(k, lambda)), -1, 0.0, [&](double j) { return j / lambda; });
    upper = 1.0 - lower;
  } else {
    upper = sum_away_from_mode(k + 1, std::exp(poisson_log_pmf(k + 1, lambda)), +1, -1.0,
                               [&](double j) { return lambda / (j + 1); });
    lower = 1.0 - upper;
  }
}

// Both tails of the binomial at k (integer n), exact edge cases first.
void binomial_tails(double k, double n, double p, double& lower, double& upper, int method) {
  if (k < 0) {
    lower = 0;
    upper = 1;
    return;
  }
  if (k >= n) {
    lower = 1;
    upper = 0;
    return;
  }
  if (p == 0.0) {
    lower = 1;
    upper = 0;
    return;
  }
  if (p == 1.0) {
    lower = 0;
    upper = 1;
    return;
  }
  // p > 1/2 through the failures, K' = n - K ~ Binomial(n, 1 - p) with 1 - p exact:
  // P(K <= k) = P(K' >= n - k) = P(K' > n - k - 1).
  if (p > 0.5) {
    binomial_tails(n - k - 1, n, 1.0 - p, upper, lower, method);
    return;
  }
  const double var = n * p * (1 - p);
  const bool saddle = method == 0 ? var > kTailSumVariance : method == 2;
  if (saddle)
    binomial_saddle(k + 1, n, p, upper, lower);  // P(K >= k + 1) = P(K > k)
  else
    binomial_sum(k, n, p, lower, upper);
}

void poisson_tails(double k, double lambda, double& lower, double& upper, int method) {
  if (k < 0) {
    lower = 0;
    upper = 1;
    return;
  }
  if (lambda == 0.0) {
    lower = 1;
    upper = 0;
    return;
  }
  const bool saddle = method == 0 ? lambda > kTailSumVariance : method == 2;
  if (saddle)
    poisson_saddle(k + 1, lambda, upper, lower);
  else
    poisson_sum(k, lambda, lower, upper);
}

}  // namespace

double binomial_lower_tail(double k, double n, double p) {
  double lo, up;
  binomial_tails(k, n, p, lo, up, 0);
  return lo;
}
double binomial_upper_tail(double k, double n, double p) {
  double lo, up;
  binomial_tails(k, n, p, lo, up, 0);
  return up;
}
double poisson_lower_tail(double k, double lambda) {
  double lo, up;
  poisson_tails(k, lambda, lo, up, 0);
  return lo;
}
double poisson_upper_tail(double k, double lambda) {
  double lo, up;
  poisson_tails(k, lambda, lo, up, 0);
  return up;
}
double binomial_upper_tail_sum(double k, double n, double p) {
  double lo, up;
  binomial_tails(k, n, p, lo, up, 1);
  return up;
}
double binomial_upper_tail_saddle(double k, double n, double p) {
  double lo, up;
  binomial_tails(k, n, p, lo, up, 2);
  return up;
}
double poisson_upper_tail_sum(double k, double lambda) {
  double lo, up;
  poisson_tails(k, lambda, lo, up, 1);
  return up;
}
double poisson_upper_tail_saddle(double k, double lambda) {
  double lo, up;
  poisson_tails(k, lambda, lo, up, 2);
  return up;
}

}  // namespace glintlab::special
