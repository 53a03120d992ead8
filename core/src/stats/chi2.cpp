#include "glintlab/stats/chi2.hpp"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"

namespace glintlab {

namespace {

// The exact likelihood-ratio test of `obs` against the law's unmerged cells (q_k = ps[k] / mass): the
// p-value P(G_sim >= G_obs) over multinomial samples of the same size drawn from the law. Valid at any
// sample size (it never merges cells, so a sample where the law has mass 1e-12 makes G large). Ties:
// G takes few distinct values at small sizes; a G within rounding of the observed one counts as "at
// least as extreme" (the p-value stays valid, i.e. conservative).
struct ExactLr {
  double pvalue = 1.0, resolution = 0.0;
  std::string how;
};

double tie_tolerance(double g_obs) { return 1e-9 * std::max(1.0, std::abs(g_obs)); }

// log C(count + cells - 1, cells - 1): the number of possible count vectors (the "types").
double log_types(std::size_t count, std::size_t cells) {
  const double n = static_cast<double>(count), m = static_cast<double>(cells);
  return std::lgamma(n + m) - std::lgamma(n + 1.0) - std::lgamma(m);
}

// Every count vector, exactly: the sum of the multinomial probabilities of those with G >= G_obs.
// Per cell and count o, log(q^o / o!) and o log(o / e) are tabled; the recursion adds one cell at a time.
double enumerate_pvalue(const std::vector<double>& q, std::size_t count, double g_obs) {
  const std::size_t m = q.size(), n1 = count + 1;
  const double total = static_cast<double>(count);
  std::vector<double> logp(m * n1), gterm(m * n1);
  for (std::size_t k = 0; k < m; ++k)
    for (std::size_t o = 0; o <= count; ++o) {
      const double od = static_cast<double>(o);
      logp[k * n1 + o] = o == 0 ? 0.0 : od * std::log(q[k]) - std::lgamma(od + 1.0);
      gterm[k * n1 + o] = o == 0 ? 0.0 : 2.0 * od * std::log(od / (total * q[k]));
    }
  const double log_nfact = std::lgamma(total + 1.0), threshold = g_obs - tie_tolerance(g_obs);
  double p = 0.0;
  // Depth-first over cells 0..m-2 with `left` samples still to place; the last cell takes the rest.
  struct Rec {
    const std::vector<double>& logp;
    const std::vector<double>& gterm;
    std::size_t m, n1;
    double log_nfact, threshold;
    double& p;
    void operator()(std::size_t k, std::size_t left, double lp, double g) const {
      if (k + 1 == m) {
        const double gg = g + gterm[k * n1 + left];
        if (gg >= threshold) p += std::exp(log_nfact + lp + logp[k * n1 + left]);
        return;
      }
      for (std::size_t o = 0; o <= left; ++o) (*this)(k + 1, left - o, lp + logp[k * n1 + o], g + gterm[k * n1 + o]);
    }
  };
  Rec{logp, gterm, m, n1, log_nfact, threshold, p}(0, count, 0.0, 0.0);
  return std::min(p, 1.0);
}

// Counts the Monte Carlo draws [first, last) whose G is at least G_obs (draw d uses its own counter-
// based stream, so more draws extend the same sequence and the same samples keep their p-value).
std::size_t extreme_draws(const std::vector<double>& q, std::size_t count, double g_obs, std::size_t first,
                          std::size_t last) {
  std::vector<double> cdf(q.size());
  double acc = 0.0;
  for (std::size_t k = 0; k < q.size(); ++k) cdf[k] = (acc += q[k]);
  const double total = static_cast<double>(count), threshold = g_obs - tie_tolerance(g_obs);
  std::size_t extreme = 0;
  std::vector<std::size_t> cells(count);
  std::vector<std::pair<std::size_t, double>> sim;
  for (std::size_t d = first; d < last; ++d) {
    CounterRng rng(0x676c696e746c6162ULL, static_cast<std::uint32_t>(d), static_cast<std::uint32_t>(d >> 32), 0,
                   0x4c52);
    for (auto& c : cells) {
      const double u = rng.uniform() * acc;
      c = static_cast<std::size_t>(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
      if (c >= q.size()) c = q.size() - 1;
    }
    std::sort(cells.begin(), cells.end());
    sim.clear();
    for (std::size_t i = 0; i < cells.size();) {
      std::size_t j = i;
      while (j < cells.size() && cells[j] == cells[i]) ++j;
      sim.emplace_back(cells[i], static_cast<double>(j - i));
      i = j;
    }
    double g = 0.0;
    for (const auto& [k, o] : sim) g += o * std::log(o / (total * q[k]));
    if (2.0 * g >= threshold) ++extreme;
  }
  return extreme;
}

// The test, computed as exactly as its size allows:
//  1. at most kEnumerate count vectors: every one of them (p exact, resolution 0);
//  2. else the method-of-types bound P(G >= g) <= types exp(-g / 2) (each type T has probability at
//     most exp(-count KL(T || q)) and G = 2 count KL), when it is below what the Monte Carlo
//     estimate could resolve, or (given alpha) below alpha: the decision is then certain;
//  3. else Monte Carlo, (1 + #{G_sim >= G_obs}) / (1 + draws), never below 1 / (1 + draws): with
//     `alpha`, draws are doubled until alpha is clearly on one side of the estimate (which needs a
//     resolution below alpha to reject), within a cap of kMaxValues sampled values; a decision still open at the cap
//     gives a NaN p-value (a check cannot pass on it) and says so.
ExactLr exact_lr_pvalue(const std::vector<double>& obs, const std::vector<double>& ps, double mass, std::size_t count,
                        double alpha) {
  constexpr double kEnumerate = 2e6;  // count vectors: ~0.05 s
  constexpr double kMaxValues = 4e7;  // Monte Carlo sampled values: a few seconds at most
  std::vector<double> q;              // cells of positive mass (the others cannot be observed)
  std::vector<std::size_t> index;
  double g_obs = 0.0;
  const double total = static_cast<double>(count);
  for (std::size_t k = 0; k < ps.size(); ++k) {
    if (!(ps[k] > 0)) continue;
    q.push_back(ps[k] / mass);
    if (obs[k] > 0) g_obs += obs[k] * std::log(obs[k] / (total * q.back()));
  }
  g_obs *= 2.0;
  ExactLr r;
  const double lt = log_types(count, q.size());
  if (lt <= std::log(kEnumerate)) {
    r.pvalue = enumerate_pvalue(q, count, g_obs);
    r.how = "exact p-value by enumeration of all " + format_value(std::round(std::exp(lt))) + " outcomes";
    return r;
  }
  const double bound = std::exp(lt - 0.5 * g_obs);
  std::size_t draws = std::clamp<std::size_t>(10'000'000 / std::max<std::size_t>(count, 1), 999, 9999);
  const std::size_t max_draws =
      std::max<std::size_t>(draws, static_cast<std::size_t>(kMaxValues / std::max(total, 1.0)));
  if (bound * (1.0 + static_cast<double>(draws)) < 1.0 || (alpha > 0 && bound <= alpha)) {
    r.pvalue = bound;
    r.how = "p-value bounded above by the method of types (" + format_value(std::exp(lt)) +
            " outcomes x exp(-G/2)), below what Monte Carlo could resolve";
    return r;
  }
  std::size_t extreme = extreme_draws(q, count, g_obs, 0, draws);
  const auto estimate = [&] { return static_cast<double>(extreme + 1) / static_cast<double>(draws + 1); };
  // The decision p <= alpha is clear when alpha lies outside [lo, hi], bounds on the p-value from the
  // count of extreme draws X ~ Binomial(draws, p) about 5 standard deviations wide (hi also when X = 0:
  // P(X = 0) = exp(-20) at p = 20 / draws). hi < alpha needs a resolution 1 / (1 + draws) < alpha.
  const auto decided = [&] {
    const double x = static_cast<double>(extreme), b = static_cast<double>(draws);
    const double hi = (x + 1.0) / (b + 1.0) + (5.0 * std::sqrt(x + 1.0) + 14.0) / b;
    const double lo = (x - 5.0 * std::sqrt(x)) / b;
    return hi < alpha || lo > alpha;
  };
  while (alpha > 0 && !decided() && draws < max_draws) {
    const std::size_t more = std::min(draws, max_draws - draws);
    extreme += extreme_draws(q, count, g_obs, draws, draws + more);
    draws += more;
  }
  r.pvalue = estimate();
  r.resolution = 1.0 / static_cast<double>(draws + 1);
  r.how = "Monte Carlo p-value from " + std::to_string(draws) + " multinomial draws of the law (resolution " +
          format_value(r.resolution) + ")";
  if (alpha > 0 && !decided()) {
    r.how += "; the decision at alpha = " + format_value(alpha) + " is still open after the cap of " +
             std::to_string(max_draws) + " draws, so the p-value is NaN";
    r.pvalue = std::numeric_limits<double>::quiet_NaN();
  }
  return r;
}

}  // namespace

Chi2Result chi2_test(const double* samples, std::size_t count, const Distribution& law, double min_expected,
                     int fitted_params, double alpha) {
  constexpr const char* where = "chi2_test";
  if (count == 0) throw_invalid_message("chi2_test: samples is empty");
  if (!(min_expected > 0.0) || !std::isfinite(min_expected))
    throw_invalid(where, "min_expected", min_expected, "a finite number > 0");
  if (fitted_params < 0) throw_invalid(where, "fitted_params", fitted_params, "an integer >= 0");
  if (!(alpha >= 0.0 && alpha < 1.0)) throw_invalid(where, "alpha", alpha, "a number in [0, 1) (0: not given)");

  const auto& xs = law.support();
  const auto& ps = law.probs();
  const std::size_t m = xs.size();
  Chi2Result r;
  r.samples = count;

  // Observed counts per support point; impossible samples counted separately.
  std::vector<double> obs(m, 0.0);
  std::size_t impossible = 0;
  double first_impossible = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    const double s = samples[i];
    if (!std::isfinite(s)) throw_invalid(where, indexed_name("samples", i, true), s, "finite samples");
    // Beyond the support: part of the open-ended tail bin if the law's tail was trimmed there
    // (and the value is on the integer lattice), impossible otherwise.
    const bool lattice = std::floor(s) == s;
    if (s < xs.front() && law.trimmed_below() && lattice) {
      obs.front() += 1;
      continue;
    }
    if (s > xs.back() && law.trimmed_above() && lattice) {
      obs.back() += 1;
      continue;
    }
    const auto it = std::lower_bound(xs.begin(), xs.end(), s);
    if (it != xs.end() && *it == s) {
      obs[static_cast<std::size_t>(it - xs.begin())] += 1;
    } else {
      if (impossible++ == 0) first_impossible = s;
    }
  }

  // Expected counts, normalized by the law's mass (a trimmed law holds 1 - 1e-14), merged by merge_starts.
  const double total = static_cast<double>(count), mass = law.total_mass();
  std::vector<double> exp_cells(m);
  for (std::size_t i = 0; i < m; ++i) exp_cells[i] = total * ps[i] / mass;
  const auto starts = merge_starts(exp_cells.data(), m, min_expected);
  for (std::size_t g = 0; g < starts.size(); ++g) {
    const std::size_t end = g + 1 < starts.size() ? starts[g + 1] : m;
    double acc_e = 0.0, acc_o = 0.0;
    for (std::size_t i = starts[g]; i < end; ++i) {
      acc_e += exp_cells[i];
      acc_o += obs[i];
    }
    r.lower.push_back(xs[starts[g]]);
    r.upper.push_back(xs[end - 1]);
    r.expected.push_back(acc_e);
    r.observed.push_back(acc_o);
  }

  if (impossible > 0) {
    r.statistic = std::numeric_limits<double>::infinity();
    r.dof = std::max(0, static_cast<int>(r.expected.size()) - 1 - fitted_params);
    r.pvalue = 0.0;
    r.note = std::to_string(impossible) +
             " sample(s) fall on values the law gives probability 0 (first: " + format_value(first_impossible) + ")";
    return r;
  }
  for (std::size_t b = 0; b < r.expected.size(); ++b) {
    const double d = r.observed[b] - r.expected[b];
    r.statistic += d * d / r.expected[b];
  }
  r.dof = static_cast<int>(r.expected.size()) - 1 - fitted_params;
  if (r.dof < 1 && fitted_params > 0) {
    // No degrees of freedom left: no test, and no p-value that could pass for one.
    r.dof = 0;
    r.pvalue = std::numeric_limits<double>::quiet_NaN();
    r.note = std::to_string(r.expected.size()) + " bin(s) with expected count >= " + format_value(min_expected) +
             " leave no degrees of freedom after fitted_params = " + std::to_string(fitted_params) +
             ": the test cannot reject (NaN p-value; use more samples)";
    return r;
  }
  if (r.dof < 1) {
    // Too few samples for the chi-square approximation (fewer than two merged bins). Merging would
    // hide the evidence that matters most here: a sample on a value of tiny probability. So the
    // unmerged cells are tested exactly instead (see exact_lr_pvalue).
    r.dof = 0;
    const ExactLr lr = exact_lr_pvalue(obs, ps, mass, count, alpha);
    r.pvalue = lr.pvalue;
    r.resolution = lr.resolution;
    r.note = "too few samples for the chi-square approximation (fewer than two bins with expected count >= " +
             format_value(min_expected) + "): exact likelihood-ratio test on the unmerged values, " + lr.how;
    return r;
  }
  const boost::math::chi_squared_distribution<double> chi2(r.dof);
  r.pvalue = boost::math::cdf(boost::math::complement(chi2, r.statistic));
  return r;
}

std::vector<std::size_t> merge_starts(const double* expected, std::size_t m, double min_expected) {
  std::vector<std::size_t> starts;
  std::size_t start = 0;
  double acc = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    acc += expected[i];
    if (acc >= min_expected) {
      starts.push_back(start);
      start = i + 1;
      acc = 0.0;
    }
  }
  // A remainder below min_expected joins the last bin (or is the only one).
  if (start < m && starts.empty()) starts.push_back(start);
  return starts;
}

double sidak_alpha(double alpha, int tests) {
  if (!(alpha > 0.0 && alpha < 1.0)) throw_invalid("sidak_alpha", "alpha", alpha, "a number in (0, 1)");
  if (tests < 1) throw_invalid("sidak_alpha", "tests", tests, "an integer >= 1");
  return -std::expm1(std::log1p(-alpha) / tests);
}

}  // namespace glintlab
