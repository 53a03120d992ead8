// Example glintlab plugin: two counting laws in plain C++ that include nothing from glintlab but
// core/include/glintlab/plugin.h and link no glintlab library. What a renderer team would write
// around its shader's law:
//
//   g++ -O2 -shared -fPIC -I core/include validation/plugins/example_law.cpp -o libexample.so
//   python: gl.load_plugin("./libexample.so"); gl.law("example_binomial_inversion").sample(...)
//
// "example_binomial_inversion": exact inversion of the (stratified) binomial, with its pmf, so that
//   tests can check the whole round trip against glintlab's own exact binomial:
//   K = smallest k with P(K <= k) >= u[0], K ~ Binomial(m, p) + Bernoulli(f p) for n = m + f
//   (glintlab's rule for non-integer n: m whole facets and one facet covered by the fraction f).
//   Domain of the exact law: n <= 1e5 (the cost of one evaluation grows like sqrt(n p q); u is
//   clamped to [2^-53, 1 - 2^-53] as glintlab's quantiles do). Above 1e5 evaluate falls back to
//   the rounded normal below and pmf returns GLINTLAB_PMF_NONE: no exact law there.
// "example_round_normal": a shader-style law without pmf, the real clamp(n p + sqrt(n p q) z, 0, n)
//   with z = Phi^-1(u[0]) (Acklam's rational approximation refined by one Halley step on erfc);
//   glintlab bins it round half up (binning "round").
//
// Every callback is a pure function of its arguments (thread-safe, deterministic) and noexcept.
#include <cmath>

#include "glintlab/plugin.h"

namespace {

constexpr double kMaxExactN = 1e5;
// The tail beyond the walk is dropped once a geometric bound on it falls below this (relative to
// the mode's weight 1, so relative to a total mass >= 1).
constexpr double kTailBound = 1e-17;

// Phi^-1(u): Acklam's approximation (relative error 1.15e-9) and one Halley step, which brings it
// to about machine precision. u <= 0 and u >= 1 give -inf and +inf.
double normal_quantile(double u) noexcept {
  if (!(u > 0.0)) return -INFINITY;
  if (!(u < 1.0)) return INFINITY;
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01, -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double lo = 0.02425;
  double x;
  if (u < lo || u > 1.0 - lo) {
    const double q = std::sqrt(-2.0 * std::log(u < lo ? u : 1.0 - u));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
    if (u > lo) x = -x;
  } else {
    const double q = u - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  }
  // Halley step on Phi(x) - u, Phi(x) = erfc(-x / sqrt 2) / 2.
  const double e = 0.5 * std::erfc(-x / std::sqrt(2.0)) - u;
  const double g = e * 2.5066282746310002 * std::exp(x * x / 2.0);  // e / phi(x)
  return x - g / (1.0 + x * g / 2.0);
}

double round_normal(double n, double p, const double* u) noexcept {
  const double mean = n * p, sd = std::sqrt(mean * (1.0 - p));
  // sd = 0 would give 0 * inf = NaN at u in {0, 1}: the law is then the point n p.
  const double g = sd > 0.0 ? mean + sd * normal_quantile(u[0]) : mean;
  return g < 0.0 ? 0.0 : (g > n ? n : g);  // clamp; +-inf map to the ends
}

// The binomial(m, p) weights relative to the mode (weight 1) by the ratio recurrence, which needs
// no log-gamma and no normalizing constant: walking out from the mode, w(k+1) / w(k) =
// (m - k) p / ((k + 1) q). Finds [lo, hi], where the walk stops on each side once the remaining
// tail is below kTailBound (the ratios keep falling away from the mode, so a geometric series
// bounds it), and the total weight. 0 < p < 1.
struct Walk {
  double m, p, q, mode, lo, hi, w_lo, total;
};

Walk walk(double m, double p) noexcept {
  Walk s{m, p, 1.0 - p, std::floor((m + 1.0) * p), 0, 0, 1.0, 1.0};
  if (s.mode > m) s.mode = m;
  const double up = p / s.q, down = s.q / p;
  double w = 1.0, k = s.mode;
  while (k > 0) {  // down: w(k-1) = w(k) k q / ((m - k + 1) p)
    const double r = k / (m - k + 1.0) * down;
    w *= r;
    k -= 1.0;
    s.total += w;
    if (r < 1.0 && w * r / (1.0 - r) < kTailBound) break;
  }
  s.lo = k;
  s.w_lo = w;
  w = 1.0;
  k = s.mode;
  while (k < m) {
    const double r = (m - k) / (k + 1.0) * up;
    w *= r;
    k += 1.0;
    s.total += w;
    if (r < 1.0 && w * r / (1.0 - r) < kTailBound) break;
  }
  s.hi = k;
  return s;
}

// Calls f(k, P(K = k)) for the stratified law K = B + Bernoulli(fp), B ~ walk, k = lo .. hi (+1
// when fp > 0), in order, until f returns true. Returns whether it did.
template <class F>
bool for_each_prob(const Walk& s, double fp, F f) noexcept {
  double b_prev = 0.0, b = s.w_lo / s.total;
  for (double k = s.lo; k <= s.hi + (fp > 0.0 ? 1.0 : 0.0); k += 1.0) {
    const double bk = k <= s.hi ? b : 0.0;
    if (f(k, bk * (1.0 - fp) + b_prev * fp)) return true;
    b_prev = bk;
    b *= (s.m - k) / (k + 1.0) * (s.p / s.q);
  }
  return false;
}

double binomial_inversion(double n, double p, const double* u) noexcept {
  if (n > kMaxExactN) return std::floor(round_normal(n, p, u) + 0.5);
  constexpr double eps = 0x1p-53;
  const double v = u[0] < eps ? eps : (u[0] > 1.0 - eps ? 1.0 - eps : u[0]);
  const double m = std::floor(n), fp = (n - m) * p;
  if (p == 0.0) return 0.0;
  if (p == 1.0) return v <= 1.0 - (n - m) ? m : m + 1.0;  // K = m + Bernoulli(f)
  const Walk s = walk(m, p);
  double cdf = 0.0, last = s.lo, k_out = -1.0;
  for_each_prob(s, fp, [&](double k, double prob) {
    cdf += prob;
    if (prob > 0.0) last = k;
    if (cdf >= v) k_out = k;
    return k_out >= 0.0;
  });
  // Rounding can leave the summed cdf a few ulps short of u near 1: the last possible count.
  return k_out >= 0.0 ? k_out : last;
}

long long binomial_pmf(double n, double p, double* probs, long long capacity, long long* first_k,
                       int* trimmed) noexcept {
  if (n > kMaxExactN) return GLINTLAB_PMF_NONE;
  const double m = std::floor(n), f = n - m, fp = f * p;
  if (p == 0.0 || p == 1.0) {  // K = 0, or K = m + Bernoulli(f)
    const long long len = (p == 1.0 && f > 0.0) ? 2 : 1;
    if (capacity < len) return GLINTLAB_PMF_CAPACITY;
    *first_k = p == 0.0 ? 0 : static_cast<long long>(m);
    probs[0] = len == 2 ? 1.0 - f : 1.0;
    if (len == 2) probs[1] = f;
    return len;
  }
  const Walk s = walk(m, p);
  const long long len = static_cast<long long>(s.hi - s.lo) + 1 + (fp > 0.0 ? 1 : 0);
  if (capacity < len) return GLINTLAB_PMF_CAPACITY;
  *first_k = static_cast<long long>(s.lo);
  *trimmed = (s.lo > 0.0 ? GLINTLAB_TRIMMED_BELOW : 0) | (s.hi < m ? GLINTLAB_TRIMMED_ABOVE : 0);
  long long i = 0;
  for_each_prob(s, fp, [&](double, double prob) {
    probs[i++] = prob;
    return false;
  });
  return len;
}

}  // namespace

GLINTLAB_PLUGIN(glintlab::plugin::law("example_binomial_inversion",
                                      "example plugin: exact inversion of the (stratified) binomial, n <= 1e5", 1,
                                      binomial_inversion)
                    .with_pmf(binomial_pmf),
                glintlab::plugin::law("example_round_normal",
                                      "example plugin: real clamp(n p + sqrt(n p q) z, 0, n), binned round half up", 1,
                                      round_normal)
                    .with_binning("round"))
