#include "glintlab/stats/binomial.hpp"

#include <algorithm>
#include <boost/math/special_functions/erf.hpp>
#include <cmath>
#include <functional>
#include <limits>

#include "binomial_simd.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/uniform_rows.hpp"
#include "glintlab/stats/special.hpp"
#include "simd/simd_math.hpp"

namespace glintlab {

namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();
// Quantiles clamp u to [2^-53, 1 - 2^-53], the range of the samplers' own uniforms: u = 1 gives a
// finite K, u = 0 a possible one (never a K of probability zero), and K is continuous in u at both ends.
constexpr double kMaxU = 1.0 - 0x1.0p-53;
constexpr double kMinU = 0x1.0p-53;

bool is_integer(double k) { return std::floor(k) == k; }

double log_add(double a, double b) {
  if (a == kNegInf) return b;
  if (b == kNegInf) return a;
  const double hi = std::max(a, b), lo = std::min(a, b);
  return hi + std::log1p(std::exp(lo - hi));
}

// Smallest integer k in [lo, hi] with cdf(k) >= u, written as the complementary test sf(k) <= 1 - u
// when u > 1/2 so that upper-tail quantiles keep their precision. `guess` seeds an exponential then
// binary search, so the cost is O(log |k - guess|) distribution-function calls.
double discrete_inverse(double u, double lo, double hi, double guess, const std::function<double(double)>& cdf_fn,
                        const std::function<double(double)>& sf_fn) {
  const bool upper = u > 0.5;
  const double tail = 1.0 - u;  // exact for u >= 1/2 (Sterbenz)
  auto reached = [&](double k) { return upper ? sf_fn(k) <= tail : cdf_fn(k) >= u; };
  double k = std::clamp(std::floor(guess), lo, hi);
  double a, b;  // invariant at the end: !reached(a) (or a = lo - 1), reached(b)
  if (reached(k)) {
    b = k;
    double step = 1;
    for (;;) {
      const double t = std::max(lo - 1, b - step);
      if (t < lo || !reached(t)) {
        a = t;
        break;
      }
      b = t;
      step *= 2;
    }
  } else {
    a = k;
    double step = 1;
    for (;;) {
      const double t = std::min(hi, a + step);
      if (t >= hi || reached(t)) {
        b = t;
        break;
      }
      a = t;
      step *= 2;
    }
  }
  while (b - a > 1) {
    const double mid = std::floor(a + (b - a) / 2);
    if (reached(mid))
      b = mid;
    else
      a = mid;
  }
  return b;
}

double normal_guess(double u, double mean, double sd) {
  // Phi^-1(u) = -sqrt(2) erfc^-1(2u): finite for every u in [1e-300, 1 - 2^-53].
  const double uu = std::clamp(u, 1e-300, 1.0 - 0x1.0p-53);
  return mean - sd * std::sqrt(2.0) * boost::math::erfc_inv(2.0 * uu);
}

void check_np(const char* where, double n, double p) {
  check_n(where, n);
  check_p(where, p);
}

// Integer-n binomial distribution functions (k an integer); see special.hpp for the method.
double bin_cdf_int(double k, double n, double p) { return special::binomial_lower_tail(k, n, p); }
double bin_sf_int(double k, double n, double p) { return special::binomial_upper_tail(k, n, p); }

}  // namespace

namespace binomial {

double mean(double n, double p) {
  check_np("binomial.mean", n, p);
  return n * p;
}

double variance(double n, double p) {
  check_np("binomial.variance", n, p);
  const double m = std::floor(n), g = (n - m) * p;
  return m * p * (1.0 - p) + g * (1.0 - g);
}

double log_pmf(double k, double n, double p) {
  check_np("binomial.log_pmf", n, p);
  if (std::isnan(k)) throw_invalid("binomial.log_pmf", "k", k, "a number");
  if (!is_integer(k)) return kNegInf;
  const double m = std::floor(n), g = (n - m) * p;
  if (g == 0.0) return special::binomial_log_pmf_int(k, m, p);
  // (1 - g) b(k; m, p) + g b(k - 1; m, p), combined in log space.
  return log_add(std::log1p(-g) + special::binomial_log_pmf_int(k, m, p),
                 std::log(g) + special::binomial_log_pmf_int(k - 1, m, p));
}

double pmf(double k, double n, double p) { return std::exp(log_pmf(k, n, p)); }

double cdf(double k, double n, double p) {
  check_np("binomial.cdf", n, p);
  if (std::isnan(k)) throw_invalid("binomial.cdf", "k", k, "a number");
  k = std::floor(k);
  const double m = std::floor(n), g = (n - m) * p;
  if (g == 0.0) return bin_cdf_int(k, m, p);
  return (1.0 - g) * bin_cdf_int(k, m, p) + g * bin_cdf_int(k - 1, m, p);
}

double sf(double k, double n, double p) {
  check_np("binomial.sf", n, p);
  if (std::isnan(k)) throw_invalid("binomial.sf", "k", k, "a number");
  k = std::floor(k);
  const double m = std::floor(n), g = (n - m) * p;
  if (g == 0.0) return bin_sf_int(k, m, p);
  return (1.0 - g) * bin_sf_int(k, m, p) + g * bin_sf_int(k - 1, m, p);
}

double quantile(double u, double n, double p) {
  check_np("binomial.quantile", n, p);
  check_u("binomial.quantile", u);
  const double m = std::floor(n), hi = (n > m && p > 0) ? m + 1 : m;
  if (p == 0.0) return 0.0;
  const double sd = std::sqrt(std::max(m * p * (1 - p), 0.25));
  const double uu = std::clamp(u, kMinU, kMaxU);
  return discrete_inverse(
      uu, 0.0, hi, normal_guess(uu, n * p, sd), [&](double k) { return cdf(k, n, p); },
      [&](double k) { return sf(k, n, p); });
}

QuantileTable::QuantileTable(double n, double p, std::size_t rows) : n_(n), p_(p) {
  check_np("binomial.quantile", n, p);
  if (p == 0.0) return;  // quantile answers 0 before looking at u
  const double m = std::floor(n), hi = (n > m && p > 0) ? m + 1 : m;
  // The window holds about 17 sd + 40 counts, each costing two tail evaluations (a few of quantile's
  // ~20): tabulate only when that is well below `rows` quantiles.
  const double sd = std::sqrt(std::max(m * p * (1 - p), 0.25));
  const double expected = 17.0 * sd + 40.0;
  if (expected > 0.5 * static_cast<double>(rows) || expected > static_cast<double>(1 << 20)) return;
  // Down from the mean to the first k with cdf(k) < 2^-54 (or 0), up to the first with sf(k) <= 2^-54
  // (or hi). Outside the window the predicate is then settled: every u' >= 2^-53 sees cdf < u' and
  // sf > 1/2 > 1 - u' below it, cdf >= 1/2 and sf <= 1 - u' above it; the factor 2 between the
  // window's end values and 2^-53 covers the tails' relative error (computed directly, special.hpp),
  // so a count beyond the window cannot cross the clamped u' where its neighbour in the window did not.
  const double limit = 4.0 * expected + 100.0;
  const double start = std::clamp(std::floor(n * p), 0.0, hi);
  double lo = start, top = start;
  while (lo > 0 && cdf(lo, n, p) >= 0.5 * kMinU && start - lo < limit) lo -= 1;
  while (top < hi && sf(top, n, p) > 0.5 * kMinU && top - start < limit) top += 1;
  if (start - lo >= limit || top - start >= limit) return;
  const std::size_t size = static_cast<std::size_t>(top - lo) + 1;
  std::vector<double> c(size), s(size);
  for (std::size_t i = 0; i < size; ++i) {
    c[i] = cdf(lo + static_cast<double>(i), n, p);
    s[i] = sf(lo + static_cast<double>(i), n, p);
    if (!std::isfinite(c[i]) || !std::isfinite(s[i])) return;
  }
  // Where the computed cdf decreases (c[j] < c[i], i < j), u' in (c[j], c[i]] is reached at i but not
  // at j: the search's answer depends on its path. Same for sf increasing, 1 - u' in [s[i], s[j]).
  // One interval each covers all such u' (usually none: then empty).
  double run_max = c[0], run_min = s[0];
  for (std::size_t j = 1; j < size; ++j) {
    if (c[j] < run_max) {
      cdf_bad_lo_ = std::min(cdf_bad_lo_, c[j]);
      cdf_bad_hi_ = std::max(cdf_bad_hi_, run_max);
    }
    if (s[j] > run_min) {
      sf_bad_lo_ = std::min(sf_bad_lo_, run_min);
      sf_bad_hi_ = std::max(sf_bad_hi_, s[j]);
    }
    run_max = std::max(run_max, c[j]);
    run_min = std::min(run_min, s[j]);
  }
  // Cells of u: a power of 2, about 4 per count. Start points are lower bounds of the answer for every
  // u of the cell (first i with c >= the cell's left edge <= first i with c >= u).
  std::size_t cells = 64;
  while (cells < 4 * size && cells < (std::size_t{1} << 16)) cells *= 2;
  cells_ = static_cast<double>(cells);
  start_lo_.resize(cells / 2 + 1);
  start_hi_.resize(cells / 2 + 1);
  // Edges grow with q (tail edges shrink), so each first index only moves forward.
  std::size_t first_c = 0, first_s = 0;
  for (std::size_t q = 0; q <= cells / 2; ++q) {
    const double edge = static_cast<double>(q) / cells_;                         // u >= edge in cell q
    const double tail_edge = 1.0 - static_cast<double>(cells / 2 + q) / cells_;  // 1 - u <= tail_edge
    while (first_c < size && c[first_c] < edge) ++first_c;
    while (first_s < size && s[first_s] > tail_edge) ++first_s;
    start_lo_[q] = static_cast<std::uint32_t>(first_c);
    start_hi_[q] = static_cast<std::uint32_t>(first_s);
  }
  first_k_ = lo;
  window_reaches_zero_ = lo == 0;
  cdf_ = std::move(c);
  sf_ = std::move(s);
}

double QuantileTable::operator()(double u) const {
  if (p_ == 0.0) return 0.0;
  if (cdf_.empty()) return fallback(u);
  // quantile's rule on its clamped u', step by step (discrete_inverse): the smallest k with
  // cdf(k) >= u' when u' <= 1/2, else the smallest k with sf(k) <= 1 - u'.
  const double uu = std::clamp(u, kMinU, kMaxU);
  const std::size_t size = cdf_.size();
  std::size_t i;
  if (!(uu > 0.5)) {
    if (uu > cdf_bad_lo_ && uu <= cdf_bad_hi_) return fallback(u);
    i = start_lo_[static_cast<std::size_t>(uu * cells_)];
    while (i < size && cdf_[i] < uu) ++i;
  } else {
    const double tail = 1.0 - uu;
    if (tail >= sf_bad_lo_ && tail < sf_bad_hi_) return fallback(u);
    i = start_hi_[static_cast<std::size_t>(uu * cells_) - static_cast<std::size_t>(cells_ / 2)];
    while (i < size && sf_[i] > tail) ++i;
  }
  // An answer at the window's start (when it is not 0) or past its end is not proven by the table.
  if (i == size || (i == 0 && !window_reaches_zero_)) return fallback(u);
  return first_k_ + static_cast<double>(i);
}

Distribution distribution(double n, double p, std::size_t max_support) {
  check_np("binomial.distribution", n, p);
  const double m = std::floor(n);
  const double hi = (n > m && p > 0) ? m + 1 : m;
  // Width check before walking: the trimmed support spans about +-8.5 standard deviations.
  const double sd = std::sqrt(variance(n, p));
  if (std::min(hi + 1, 17.0 * sd + 40.0) > static_cast<double>(max_support))
    throw_invalid_message("binomial.distribution: n = " + format_value(n) + ", p = " + format_value(p) +
                          " needs about " + format_value(std::floor(17 * sd)) +
                          " support points, more than max_support = " + std::to_string(max_support) +
                          "; use cdf/sf/log_pmf instead");
  const double mode = std::floor((m + 1) * p);
  return Distribution::from_log_concave([&](double k) { return log_pmf(k, n, p); }, 0.0, hi, mode, max_support,
                                        "binomial.distribution");
}

// Below this mean, inversion (expected mean + 1 steps, O(1) with the table); above, BTRD/PTRD,
// which are exact only from mean 10 on and at their slowest just above it.
constexpr double kInversionMaxMean = detail::kBinomialInversionMaxMean;

namespace {

// The inversion's recursion f(k) = f(k - 1) (a / k - s) for Binomial(m, pp), pp <= 1/2, and its
// search bound (mean + 15 sd + 30, at most m): one definition for the Sampler and the per-pixel path.
struct InversionRecursion {
  double a, s, bound;
  InversionRecursion(double m, double pp, double mean)
      : a(0), s(pp / (1.0 - pp)), bound(std::min(m, std::ceil(mean + 15.0 * std::sqrt(mean) + 30.0))) {
    a = (m + 1) * s;  // ratio f(k)/f(k - 1) = (m - k + 1)/k p/q
  }
};

}  // namespace

Sampler::Sampler(double n, double p, bool tabulate) {
  check_np("binomial.sample", n, p);
  m_ = std::floor(n);
  g_ = (n - m_) * p;
  flip_ = p > 0.5;
  pp_ = flip_ ? 1.0 - p : p;
  const double mean = m_ * pp_;
  if (m_ == 0 || pp_ == 0.0) {
    method_ = Method::kConstant;
    constant_ = flip_ ? m_ : 0.0;
  } else if (mean < kInversionMaxMean) {
    method_ = Method::kInversion;
    // P(K = 0) = (1 - p)^m > e^-61 here (p <= 1/2, m p < 30): no underflow.
    const InversionRecursion rec(m_, pp_, mean);
    inversion_ = SmallMeanInversion(std::exp(m_ * std::log1p(-pp_)), rec.a, rec.s, rec.bound, tabulate);
  } else {
    method_ = Method::kBtrd;
    const double q = 1.0 - pp_;
    const double spq = std::sqrt(mean * q);
    b_ = 1.15 + 2.53 * spq;
    a_ = -0.0873 + 0.0248 * b_ + 0.01 * pp_;
    c_ = mean + 0.5;
    alpha_ = (2.83 + 5.1 / b_) * spq;
    vr_ = 0.92 - 4.2 / b_;
    inv_vr_ = 1.0 / vr_;
    urvr_ = 0.86 * vr_;
    mode_ = std::floor((m_ + 1) * pp_);
    r_ = pp_ / q;
    nr_ = (m_ + 1) * r_;
    npq_ = mean * q;
    log_ratio_ = special::BinomialLogRatio(m_, pp_, mode_, tabulate);  // 0 < mode < m: m pp >= 30
  }
}

template <class Rng>
double Sampler::btrd(Rng& rng) const {
  // Hörmann (1993), algorithm BTRD, steps 1-3.4. Step 3.3-3.4 (the final acceptance test) compares
  // log V with log f(k) - log f(mode) from Loader's saddle-point pmf, which stays accurate at
  // n = 1e15 where the paper's Stirling-difference form loses digits to cancellation.
  for (;;) {
    double v = rng.uniform();
    double u;
    if (v <= urvr_) {
      u = v * inv_vr_ - 0.43;
      return std::floor((2 * a_ / (0.5 - std::abs(u)) + b_) * u + c_);
    }
    if (v >= vr_) {
      u = rng.uniform() - 0.5;
    } else {
      u = v * inv_vr_ - 0.93;
      u = std::copysign(0.5, u) - u;
      v = rng.uniform() * vr_;
    }
    const double us = 0.5 - std::abs(u);
    const double k = std::floor((2 * a_ / us + b_) * u + c_);
    if (k < 0 || k > m_) continue;
    v = v * alpha_ / (a_ / (us * us) + b_);
    const double km = std::abs(k - mode_);
    if (km <= 15) {
      // Step 3.1: f(k)/f(mode) by the recursion f(i)/f(i-1) = ((n + 1) r - r i) / i, kept as a
      // ratio of two products so that no division is needed (<= 15 factors each, all in
      // [~30, 1e15]: no overflow or underflow).
      double num = 1.0, den = 1.0;
      const double lo = std::min(k, mode_) + 1, hi = std::max(k, mode_);
      // An integer loop counter: at counts near 2^53, i += 1 on a double could stop advancing.
      const auto steps = static_cast<int>(hi - lo);
      for (int j = 0; j <= steps; ++j) {
        const double i = lo + j;
        num *= nr_ - r_ * i;
        den *= i;
      }
      // mode < k: accept iff v <= num/den; mode > k: iff v num/den <= 1.
      if (mode_ < k ? v * den <= num : v * num <= den) return k;
      continue;
    }
    if (btrd_far_accepts(k, km, v)) return k;
  }
}

bool Sampler::btrd_far_accepts(double k, double km, double v) const {
  // Step 3.2: squeeze on log f(k)/f(mode) around the normal approximation.
  v = std::log(v);
  const double rho = (km / npq_) * (((km / 3.0 + 0.625) * km + 1.0 / 6.0) / npq_ + 0.5);
  const double t = -km * km / (2 * npq_);
  if (v < t - rho) return true;
  if (v > t + rho) return false;
  if (k == 0 || k == m_)  // the ends, outside BinomialLogRatio's domain (far in the tails)
    return v <= special::binomial_log_pmf_int(k, m_, pp_) - special::binomial_log_pmf_int(mode_, m_, pp_);
  return v <= log_ratio(k);
}

double Sampler::log_ratio(double k) const {
  const double offset = k - log_ratio_lo_;
  if (offset >= 0 && offset < static_cast<double>(log_ratio_table_.size()))
    return log_ratio_table_[static_cast<std::size_t>(offset)];
  return log_ratio_(k);
}

void Sampler::tabulate_log_ratios(std::size_t max_entries) {
  if (method_ != Method::kBtrd) return;
  // Step 3.2's final test is reached only for |k - mode| > 15 within the squeeze's reach, a few
  // standard deviations; 8.5 sd covers all but ~1e-17 of the draws (the rest compute it directly).
  const double reach = std::ceil(8.5 * std::sqrt(npq_)) + 16;
  const double lo = std::max(1.0, mode_ - reach), hi = std::min(m_ - 1, mode_ + reach);
  if (!(hi >= lo) || hi - lo + 1 > static_cast<double>(max_entries)) return;
  log_ratio_lo_ = lo;
  log_ratio_table_.resize(static_cast<std::size_t>(hi - lo) + 1);
  for (std::size_t j = 0; j < log_ratio_table_.size(); ++j)
    log_ratio_table_[j] = log_ratio_(lo + static_cast<double>(j));
}

template <class Rng>
double Sampler::draw_integer_part(Rng& rng) const {
  switch (method_) {
    case Method::kConstant: return constant_;
    case Method::kInversion: return flip_ ? m_ - inversion_(rng) : inversion_(rng);
    case Method::kBtrd: return flip_ ? m_ - btrd(rng) : btrd(rng);
  }
  return 0.0;
}

template <class Rng>
double Sampler::draw(Rng& rng) const {
  const double k = draw_integer_part(rng);
  if (g_ == 0.0) return k;
  return k + (rng.uniform() < g_ ? 1.0 : 0.0);  // the fractional facet
}

double Sampler::operator()(CounterRng& rng) const { return draw(rng); }
double Sampler::operator()(PrefetchedRng& rng) const { return draw(rng); }

namespace {
constexpr std::size_t kVectorBlock = 256;  // samples per kernel call (stack buffers)
}  // namespace

void Sampler::sample_rows(const double* u, std::uint64_t seed, std::uint64_t first_index, std::uint16_t stream,
                          std::size_t rows, double* out) const {
  const int level = detail::simd_level();
  // The portable level draws each sample with the scalar code: without SSE4.1's vector floor the
  // kernels would run one lane at a time, slower than the branchy scalar code (measured 10 %).
  if (method_ != Method::kBtrd || level == 0) {
    for (std::size_t r = 0; r < rows; ++r) {
      PrefetchedRng rng(u + 2 * r, seed, first_index + r, stream);
      out[r] = draw(rng);
    }
    return;
  }
  const detail::BtrdStep1 step{
      .m = m_, .g = g_, .flip = flip_ ? 1.0 : 0.0, .urvr = urvr_, .inv_vr = inv_vr_, .two_a = 2 * a_, .b = b_, .c = c_};
  const detail::BtrdAttempt attempt{.m = m_,
                                    .mode = mode_,
                                    .alpha = alpha_,
                                    .a = a_,
                                    .b = b_,
                                    .c = c_,
                                    .vr = vr_,
                                    .inv_vr = inv_vr_,
                                    .r = r_,
                                    .nr = nr_,
                                    .npq = npq_};
  constexpr std::size_t kPadded = kVectorBlock + 8;  // room for binomial_compact_avx512's whole-vector stores
  alignas(64) double redo[kVectorBlock], v[kPadded], u1[kPadded], k[kVectorBlock], w[kVectorBlock], log_w[kVectorBlock],
      lo[kVectorBlock], hi[kVectorBlock], state[kVectorBlock];
  std::uint32_t row_of[kPadded];
  for (std::size_t b = 0; b < rows; b += kVectorBlock) {
    const std::size_t len = std::min(kVectorBlock, rows - b);
    const double* ub = u + 2 * b;
    double* ob = out + b;
    // Step 1 on every row.
    if (level >= 2)
      detail::binomial_btrd_rows_avx512(step, ub, len, ob, redo);
    else
      detail::binomial_btrd_rows_avx2(step, ub, len, ob, redo);
    // The rest of the first attempt on the rows step 1 left (a fifth to a quarter), compacted.
    std::size_t pending = 0;
    if (level >= 2) {
      pending = detail::binomial_compact_avx512(redo, ub, len, row_of, v, u1);
    } else {
      for (std::size_t r = 0; r < len; ++r) {
        row_of[pending] = static_cast<std::uint32_t>(r);
        v[pending] = ub[2 * r];
        u1[pending] = ub[2 * r + 1];
        pending += redo[r] != 0.0;
      }
    }
    if (level >= 2)
      detail::binomial_btrd_attempt_avx512(attempt, v, u1, pending, k, w, lo, hi, state);
    else
      detail::binomial_btrd_attempt_avx2(attempt, v, u1, pending, k, w, lo, hi, state);
    // Step 3.2 compares log w with [lo, hi]: the vector log is within a few ulps of the C
    // library's, so a margin of 2^-40 |log w| proves the scalar comparison's outcome; inside it, the
    // scalar Sampler decides.
    detail::vec_log(w, log_w, pending);
    for (std::size_t j = 0; j < pending; ++j) {
      const std::size_t r = row_of[j];
      const std::uint64_t index = first_index + b + r;
      double st = state[j];
      if (st == 2.0) {
        const double margin = 0x1.0p-40 * std::abs(log_w[j]);
        if (log_w[j] < lo[j] - margin)
          st = 0.0;
        else if (log_w[j] > hi[j] + margin)
          st = 1.0;
        else
          st = btrd_far_accepts(k[j], std::abs(k[j] - mode_), w[j]) ? 0.0 : 1.0;  // btrd()'s own test
      }
      if (st == 0.0) {  // accepted by the first attempt, which drew the first block's two uniforms
        const double integer = flip_ ? m_ - k[j] : k[j];
        if (g_ == 0.0) {
          ob[r] = integer;
        } else {  // the fractional facet: the second block's first uniform
          auto rng = CounterRng::for_index(seed, index, stream);
          rng.skip_blocks(1);
          ob[r] = integer + (rng.uniform() < g_ ? 1.0 : 0.0);
        }
      } else {  // rejected: BTRD starts afresh from the second block
        auto rng = CounterRng::for_index(seed, index, stream);
        rng.skip_blocks(1);
        ob[r] = draw(rng);
      }
    }
  }
}

void sample_pixels(const double* n, const double* p, const double* u, std::uint64_t seed, std::uint64_t first_index,
                   std::uint16_t stream, std::size_t count, double* out) {
  const int level = detail::simd_level();
  if (level == 0) {  // the portable level: the scalar code (see Sampler::sample_rows)
    for (std::size_t i = 0; i < count; ++i) {
      PrefetchedRng rng(u + 2 * i, seed, first_index + i, stream);
      out[i] = Sampler(n[i], p[i])(rng);
    }
    return;
  }
  constexpr std::size_t B = kVectorBlock;
  alignas(64) double x[B], m[B], f0[B], redo[B], inv_a[B], inv_s[B], inv_bound[B];
  // The inversion's pixels past K = 0, compacted: their search state and recursion.
  alignas(64) double su0[B], sa[B], ss[B], sbound[B], sk[B], sf[B], sc[B], sstate[B];
  std::uint32_t row_of[B];
  // BTRD's pixels past step 1, compacted: their (n, p), uniforms and first-attempt outputs.
  alignas(64) double bn[B], bp[B], bv[B], bu1[B], bk[B], bw[B], blog_w[B], blo[B], bhi[B], bstate[B];
  std::uint32_t brow[B];
  for (std::size_t b = 0; b < count; b += B) {
    const std::size_t len = std::min(B, count - b);
    const double *nb = n + b, *pb = p + b, *ub = u + 2 * b;
    double* ob = out + b;
    // The inversion's P(K = 0) = exp(m log1p(-min(p, 1 - p))) by the vector functions: an
    // approximation, used only with the guard band (binomial_simd.hpp).
    if (level >= 2)
      detail::binomial_pixels_prepare_avx512(nb, pb, len, x, m);
    else
      detail::binomial_pixels_prepare_avx2(nb, pb, len, x, m);
    detail::vec_log1p(x, f0, len);
    for (std::size_t i = 0; i < len; ++i) x[i] = m[i] * f0[i];
    detail::vec_exp(x, f0, len);
    if (level >= 2)
      detail::binomial_pixels_avx512(nb, pb, ub, f0, len, ob, redo, inv_a, inv_s, inv_bound);
    else
      detail::binomial_pixels_avx2(nb, pb, ub, f0, len, ob, redo, inv_a, inv_s, inv_bound);
    const auto scalar_draw = [&](std::size_t i) {
      PrefetchedRng rng(ub + 2 * i, seed, first_index + b + i, stream);
      ob[i] = Sampler(nb[i], pb[i])(rng);
    };
    std::size_t searching = 0, attempting = 0;
    for (std::size_t i = 0; i < len; ++i) {
      if (redo[i] == 0.0) continue;
      if (redo[i] == 1.0) {
        scalar_draw(i);
        continue;
      }
      if (redo[i] == 3.0) {
        brow[attempting] = static_cast<std::uint32_t>(i);
        bn[attempting] = nb[i];
        bp[attempting] = pb[i];
        bv[attempting] = ub[2 * i];
        bu1[attempting] = ub[2 * i + 1];
        ++attempting;
        continue;
      }
      row_of[searching] = static_cast<std::uint32_t>(i);
      su0[searching] = ub[2 * i];
      sa[searching] = inv_a[i];
      ss[searching] = inv_s[i];
      sbound[searching] = inv_bound[i];
      sk[searching] = 0.0;
      sf[searching] = f0[i];
      sc[searching] = f0[i];
      ++searching;
    }
    // BTRD's first attempt past step 1, as Sampler::sample_rows does it, with each pixel's constants.
    if (level >= 2)
      detail::binomial_pixels_attempt_avx512(bn, bp, bv, bu1, attempting, bk, bw, blo, bhi, bstate);
    else
      detail::binomial_pixels_attempt_avx2(bn, bp, bv, bu1, attempting, bk, bw, blo, bhi, bstate);
    detail::vec_log(bw, blog_w, attempting);
    for (std::size_t j = 0; j < attempting; ++j) {
      const std::size_t i = brow[j];
      double st = bstate[j];
      if (st == 2.0) {  // the squeeze on the vector log, with sample_rows' proven margin
        const double margin = 0x1.0p-40 * std::abs(blog_w[j]);
        st = blog_w[j] < blo[j] - margin ? 0.0 : (blog_w[j] > bhi[j] + margin ? 1.0 : 2.0);
      }
      if (st == 0.0) {  // accepted: the reflection, then the fractional facet from the second block
        const double mi = m[i], g = (nb[i] - mi) * pb[i];
        const double integer = pb[i] > 0.5 ? mi - bk[j] : bk[j];
        if (g == 0.0) {
          ob[i] = integer;
        } else {
          auto rng = CounterRng::for_index(seed, first_index + b + i, stream);
          rng.skip_blocks(1);
          ob[i] = integer + (rng.uniform() < g ? 1.0 : 0.0);
        }
      } else if (st == 1.0) {  // rejected: BTRD starts afresh from the second block
        auto rng = CounterRng::for_index(seed, first_index + b + i, stream);
        rng.skip_blocks(1);
        ob[i] = Sampler(nb[i], pb[i])(rng);
      } else {  // within the squeeze's margin: the scalar Sampler from the start
        scalar_draw(i);
      }
    }
    // The search, eight steps at a time, on the pixels not settled yet.
    while (searching > 0) {
      if (level >= 2)
        detail::binomial_inversion_steps_avx512(su0, sa, ss, sbound, searching, sk, sf, sc, sstate);
      else
        detail::binomial_inversion_steps_avx2(su0, sa, ss, sbound, searching, sk, sf, sc, sstate);
      std::size_t still = 0;
      for (std::size_t j = 0; j < searching; ++j) {
        const std::size_t i = row_of[j];
        if (sstate[j] == 0.0) {
          // K proved; then the reflection and the fractional facet (the next uniform: u1).
          const double mi = m[i], g = (nb[i] - mi) * pb[i], k = sk[j];
          const double integer = pb[i] > 0.5 ? mi - k : k;
          ob[i] = g == 0.0 ? integer : integer + (ub[2 * i + 1] < g ? 1.0 : 0.0);
        } else if (sstate[j] == 1.0) {
          scalar_draw(i);
        } else {
          row_of[still] = row_of[j];
          su0[still] = su0[j];
          sa[still] = sa[j];
          ss[still] = ss[j];
          sbound[still] = sbound[j];
          sk[still] = sk[j];
          sf[still] = sf[j];
          sc[still] = sc[j];
          ++still;
        }
      }
      searching = still;
    }
  }
}

}  // namespace binomial

namespace poisson {

namespace {
void check_lambda(const char* where, double lambda) {
  if (!(lambda >= 0.0) || !std::isfinite(lambda)) throw_invalid(where, "lambda", lambda, "a finite mean >= 0");
}
}  // namespace

double log_pmf(double k, double lambda) {
  check_lambda("poisson.log_pmf", lambda);
  if (std::isnan(k)) throw_invalid("poisson.log_pmf", "k", k, "a number");
  if (!is_integer(k)) return kNegInf;
  return special::poisson_log_pmf(k, lambda);
}

double pmf(double k, double lambda) { return std::exp(log_pmf(k, lambda)); }

double cdf(double k, double lambda) {
  check_lambda("poisson.cdf", lambda);
  if (std::isnan(k)) throw_invalid("poisson.cdf", "k", k, "a number");
  return special::poisson_lower_tail(std::floor(k), lambda);
}

double sf(double k, double lambda) {
  check_lambda("poisson.sf", lambda);
  if (std::isnan(k)) throw_invalid("poisson.sf", "k", k, "a number");
  return special::poisson_upper_tail(std::floor(k), lambda);
}

double quantile(double u, double lambda) {
  check_lambda("poisson.quantile", lambda);
  check_u("poisson.quantile", u);
  if (lambda == 0.0) return 0.0;
  const double hi = std::ceil(lambda + 40.0 * std::sqrt(lambda) + 100.0);
  const double uu = std::clamp(u, kMinU, kMaxU);
  return discrete_inverse(
      uu, 0.0, hi, normal_guess(uu, lambda, std::sqrt(lambda)), [&](double k) { return cdf(k, lambda); },
      [&](double k) { return sf(k, lambda); });
}

Distribution distribution(double lambda, std::size_t max_support) {
  check_lambda("poisson.distribution", lambda);
  const double sd = std::sqrt(lambda);
  if (17.0 * sd + 40.0 > static_cast<double>(max_support))
    throw_invalid_message("poisson.distribution: lambda = " + format_value(lambda) + " needs more than max_support = " +
                          std::to_string(max_support) + " support points; use cdf/sf/log_pmf instead");
  return Distribution::from_log_concave([&](double k) { return log_pmf(k, lambda); }, 0.0,
                                        std::numeric_limits<double>::max(), std::floor(lambda), max_support,
                                        "poisson.distribution");
}

Sampler::Sampler(double lambda, bool tabulate) : lambda_(lambda) {
  check_lambda("poisson.sample", lambda);
  if (lambda < binomial::kInversionMaxMean) {
    inversion_ = SmallMeanInversion(std::exp(-lambda), lambda, 0.0, std::ceil(lambda + 15.0 * std::sqrt(lambda) + 30.0),
                                    tabulate);
  } else {
    ptrd_ = true;
    const double slam = std::sqrt(lambda);
    b_ = 0.931 + 2.53 * slam;
    a_ = -0.059 + 0.02483 * b_;
    log_inv_alpha_ = std::log(1.1239 + 1.1328 / (b_ - 3.4));
    vr_ = 0.9277 - 3.6224 / (b_ - 2);
  }
}

double Sampler::operator()(CounterRng& rng) const {
  if (lambda_ == 0.0) return 0.0;
  if (!ptrd_) return inversion_(rng);
  // Hörmann's PTRD; the final test uses the saddle-point log pmf (accurate for lambda ~ 1e15).
  for (;;) {
    const double u = rng.uniform() - 0.5;
    const double v = rng.uniform();
    const double us = 0.5 - std::abs(u);
    const double k = std::floor((2 * a_ / us + b_) * u + lambda_ + 0.43);
    if (us >= 0.07 && v <= vr_) return k;
    if (k < 0 || (us < 0.013 && v > us)) continue;
    if (std::log(v) + log_inv_alpha_ - std::log(a_ / (us * us) + b_) <= special::poisson_log_pmf(k, lambda_)) return k;
  }
}

}  // namespace poisson
}  // namespace glintlab
