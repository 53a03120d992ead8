// The exact binomial law of the count K of reflecting facets among n, each reflecting with
// probability p, and the Poisson law of a Poisson layout (K ~ Poisson(n p)).
//
// Non-integer n (the "stratified" rule, docs/math/ground_truth.md#gt-non-integer): n = m + f with m = floor(n), f in
// [0, 1) means m facets fully inside the footprint plus one facet covered by the fraction f, so
//   K = Binomial(m, p) + Bernoulli(f p),   E[K] = n p exactly,   Var[K] = m p q + f p (1 - f p).
// For integer n it is the ordinary binomial. This is the law of counting stratified facets in a
// footprint of area n / N made of whole cells plus one partial cell, and it keeps the mean right,
// unlike rounding n.
//
// Numerics: pmfs in log space by Loader's saddle-point method (special.hpp): accurate for
// n up to 1e15 and p down to 1e-300. CDF and survival function by pmf summation or, for variances
// above 1e7, the Lugannani-Rice saddle-point formula (special.hpp), each tail computed directly so
// that rare-glint tail masses never come from 1 - (something close to 1).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "glintlab/base/rng.hpp"
#include "glintlab/stats/distribution.hpp"
#include "glintlab/stats/inversion.hpp"
#include "glintlab/stats/special.hpp"

namespace glintlab::binomial {

double mean(double n, double p);
double variance(double n, double p);
double log_pmf(double k, double n, double p);  // -inf outside the support or for non-integer k
double pmf(double k, double n, double p);
double cdf(double k, double n, double p);  // P(K <= k)
double sf(double k, double n, double p);   // P(K > k)
// Smallest integer k with P(K <= k) >= u' (inversion; monotone in u), u in [0, 1] clamped to
// u' in [2^-53, 1 - 2^-53]: u = 1 stays finite and continuous with u -> 1 (K = mean + ~8.3 sd,
// not n), and u = 0 likewise (K = 0 when P(K = 0) >= 2^-53; n when p = 1), never an impossible K.
double quantile(double u, double n, double p);
Distribution distribution(double n, double p, std::size_t max_support = kDefaultMaxSupport);

// quantile(u, n, p) at one (n, p) for many u, bit for bit: the distribution functions quantile
// compares u against (cdf, and sf in the upper half) tabulated once over the window where its answers
// lie, and its decision rule ("the smallest k with cdf(k) >= u", or "with sf(k) <= 1 - u" above 1/2)
// applied to the table. A blend at one footprint area draws every sample of a level at one (n, p).
// Where the table cannot prove the rule's answer (a u where the computed functions are not monotone,
// or an answer outside the window) the call is quantile itself.
class QuantileTable {
 public:
  // Tabulates when the table costs less than about `rows` quantiles; otherwise every call is quantile.
  QuantileTable(double n, double p, std::size_t rows);
  double operator()(double u) const;
  bool tabulated() const { return !cdf_.empty(); }

 private:
  double fallback(double u) const { return quantile(u, n_, p_); }
  double n_, p_;
  double first_k_ = 0;                   // the window's first count
  bool window_reaches_zero_ = false;     // first_k_ == 0: an answer at the window's start is final
  std::vector<double> cdf_, sf_;         // cdf(k), sf(k) for k = first_k_ + i
  std::vector<std::uint32_t> start_lo_;  // per cell of u <= 1/2: first i with cdf_[i] >= cell's left edge
  std::vector<std::uint32_t> start_hi_;  // per cell of u >= 1/2: first i with sf_[i] <= 1 - cell's left edge
  double cells_ = 0;                     // cells per unit of u (a power of 2: u * cells_ is exact)
  // u (lower rule) or 1 - u (upper rule) where the computed functions are not monotone, so that the
  // rule's answer depends on quantile's search path: those calls are quantile's own.
  double cdf_bad_lo_ = 1, cdf_bad_hi_ = 0, sf_bad_lo_ = 1, sf_bad_hi_ = 0;
};

// The generator of sample `index` of a batch (CounterRng::for_index(seed, index, stream)) whose first
// two uniforms were computed ahead, as a row of the vectorized Philox (detail::philox_uniform_rows
// with k = 2): the same numbers in the same order, at a fraction of the scalar Philox's cost for the
// draws that need no more than two (most of them).
class PrefetchedRng {
 public:
  PrefetchedRng(const double* first_two, std::uint64_t seed, std::uint64_t index, std::uint16_t stream)
      : first_{first_two[0], first_two[1]}, rng_(CounterRng::for_index(seed, index, stream)) {
    rng_.skip_blocks(1);  // the prefetched one
  }
  double uniform() {
    if (pos_ < 2) return first_[pos_++];
    return rng_.uniform();  // past the prefetched block: the scalar generator, from its second block
  }

 private:
  double first_[2];
  int pos_ = 0;
  CounterRng rng_;
};

// Draws K with bounded expected cost: inversion (inversion.hpp) when min(p, 1 - p) m < 30,
// otherwise Hörmann's BTRD (1993, "The generation of binomial random variates"), whose expected
// number of uniforms is below 2.6 for every (n, p). The method depends on (n, p) only, so a draw is
// a function of (n, p, seed, index) whatever the batch. `tabulate` builds the inversion table
// (worth it for batches; the result is bit-identical either way). operator() is const and
// thread-safe.
class Sampler {
 public:
  Sampler(double n, double p, bool tabulate = false);
  double operator()(CounterRng& rng) const;
  double operator()(PrefetchedRng& rng) const;  // the same draw on a prefetched generator
  // Samples first_index .. first_index + rows - 1 of `stream`, given their first two uniforms as rows
  // u[2 r], u[2 r + 1] (detail::philox_uniform_rows with k = 2): out[r] is, bit for bit,
  // (*this)(PrefetchedRng(u + 2 r, seed, first_index + r, stream)). In BTRD's regime (AVX2 and
  // AVX-512 levels), the first attempt runs across samples as vector code: step 1 on every row,
  // steps 2-3.2 on the rows step 1 left; the scalar code finishes only the attempts that were
  // rejected (from the second Philox block on: 11 to 22 % of the samples) or whose squeeze is
  // undecided (its own final test).
  void sample_rows(const double* u, std::uint64_t seed, std::uint64_t first_index, std::uint16_t stream,
                   std::size_t rows, double* out) const;
  // For long batches in BTRD's regime: tabulates BTRD's final test value log f(k) - log f(mode) over
  // mode +- (8.5 sd + 16) if that takes at most max_entries values (the same values, computed
  // ahead: draws are unchanged). Worth it when the batch is many times longer than the table.
  void tabulate_log_ratios(std::size_t max_entries);

 private:
  template <class Rng>
  double draw(Rng& rng) const;
  template <class Rng>
  double draw_integer_part(Rng& rng) const;
  template <class Rng>
  double btrd(Rng& rng) const;
  // BTRD's step 3.2 for an attempt at k, km = |k - mode| > 15, v scaled by step 3: true to accept.
  bool btrd_far_accepts(double k, double km, double v) const;

  enum class Method { kConstant, kInversion, kBtrd } method_;
  double m_ = 0, g_ = 0;  // integer part of n; probability of the fractional facet (f p)
  double pp_ = 0;         // min(p, 1 - p)
  bool flip_ = false;     // p > 1/2: K = m - Binomial(m, 1 - p)
  double constant_ = 0;   // result of the integer part when it is deterministic (p in {0, 1}, m = 0)
  SmallMeanInversion inversion_;
  // BTRD
  double b_ = 0, a_ = 0, c_ = 0, alpha_ = 0, vr_ = 0, inv_vr_ = 0, urvr_ = 0, mode_ = 0, r_ = 0, nr_ = 0, npq_ = 0;
  special::BinomialLogRatio log_ratio_;  // log f(k) - log f(mode)
  std::vector<double> log_ratio_table_;  // log_ratio_(k) for k = log_ratio_lo_, ... (tabulate_log_ratios)
  double log_ratio_lo_ = 0;
  double log_ratio(double k) const;
};

// Samples with their own (n, p) each (a renderer's pixels), first two uniforms as rows u as above:
// out[r] is, bit for bit, Sampler(n[r], p[r])(PrefetchedRng(u + 2 r, seed, first_index + r, stream)),
// and bad parameters raise the Sampler's errors. The per-pixel setup and the first step of each
// method (BTRD's step 1; the inversion's search, from a vector P(K = 0) and with a guard band
// around every comparison) run as vector code across pixels; the pixels they cannot settle get the
// scalar Sampler.
void sample_pixels(const double* n, const double* p, const double* u, std::uint64_t seed, std::uint64_t first_index,
                   std::uint16_t stream, std::size_t count, double* out);

}  // namespace glintlab::binomial

namespace glintlab::poisson {

double log_pmf(double k, double lambda);
double pmf(double k, double lambda);
double cdf(double k, double lambda);
double sf(double k, double lambda);
double quantile(double u, double lambda);  // same convention as binomial::quantile
Distribution distribution(double lambda, std::size_t max_support = kDefaultMaxSupport);

// Inversion for lambda < 30 (as the binomial), Hörmann's PTRD (1993, "The transformed rejection
// method for generating Poisson random variables") above.
class Sampler {
 public:
  explicit Sampler(double lambda, bool tabulate = false);
  double operator()(CounterRng& rng) const;

 private:
  bool ptrd_ = false;
  double lambda_ = 0;
  SmallMeanInversion inversion_;
  double b_ = 0, a_ = 0, log_inv_alpha_ = 0, vr_ = 0;
};

}  // namespace glintlab::poisson
