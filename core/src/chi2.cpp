#include "glintlab/chi2.hpp"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "glintlab/errors.hpp"
#include "glintlab/rng.hpp"

namespace glintlab {

namespace {

// G = 2 sum_k o_k log(o_k / e_k) over the occupied cells of `counts` (cell k's expected count e_k =
// total q_k / mass).
double g_statistic(const std::vector<std::pair<std::size_t, double>>& occupied, const std::vector<double>& ps,
                   double mass, double total) {
  double g = 0.0;
  for (const auto& [k, o] : occupied) g += o * std::log(o / (total * ps[k] / mass));
  return 2.0 * g;
}

// The exact (Monte Carlo) likelihood-ratio test of `obs` against the law's unmerged cells: the
// p-value (1 + #{G_sim >= G_obs}) / (1 + draws) over `draws` multinomial samples of the same size
// drawn from the law with a fixed key, so the same samples always get the same p-value. Valid at any
// sample size (it never merges cells, so a sample where the law has mass 1e-12 makes G large), and
// never below 1 / (1 + draws): the draws are capped so that a call costs at most ~1e7 samples.
double exact_lr_pvalue(const std::vector<double>& obs, const std::vector<double>& ps, double mass,
                       std::size_t count, std::size_t& draws) {
  std::vector<std::pair<std::size_t, double>> occupied;
  for (std::size_t k = 0; k < obs.size(); ++k)
    if (obs[k] > 0) occupied.emplace_back(k, obs[k]);
  const double total = static_cast<double>(count);
  const double g_obs = g_statistic(occupied, ps, mass, total);
  std::vector<double> cdf(ps.size());
  double acc = 0.0;
  for (std::size_t k = 0; k < ps.size(); ++k) cdf[k] = (acc += ps[k] / mass);
  draws = std::clamp<std::size_t>(10'000'000 / std::max<std::size_t>(count, 1), 999, 9999);
  // Ties: G takes few distinct values at small sizes; a simulated G within rounding of the observed
  // one counts as "at least as extreme" (the p-value stays valid, i.e. conservative).
  const double tie = 1e-9 * std::max(1.0, std::abs(g_obs));
  std::size_t extreme = 0;
  std::vector<std::size_t> cells(count);
  for (std::size_t d = 0; d < draws; ++d) {
    CounterRng rng(0x676c696e746c6162ULL, static_cast<std::uint32_t>(d), 0, 0, 0x4c52);
    for (auto& c : cells) {
      const double u = rng.uniform() * acc;
      c = static_cast<std::size_t>(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
      if (c >= ps.size()) c = ps.size() - 1;
    }
    std::sort(cells.begin(), cells.end());
    std::vector<std::pair<std::size_t, double>> sim;
    for (std::size_t i = 0; i < cells.size();) {
      std::size_t j = i;
      while (j < cells.size() && cells[j] == cells[i]) ++j;
      sim.emplace_back(cells[i], static_cast<double>(j - i));
      i = j;
    }
    if (g_statistic(sim, ps, mass, total) >= g_obs - tie) ++extreme;
  }
  return static_cast<double>(extreme + 1) / static_cast<double>(draws + 1);
}

}  // namespace

Chi2Result chi2_test(const double* samples, std::size_t count, const Distribution& law,
                     double min_expected, int fitted_params) {
  constexpr const char* where = "chi2_test";
  if (count == 0) throw std::invalid_argument("chi2_test: samples is empty");
  if (!(min_expected > 0.0) || !std::isfinite(min_expected))
    throw_invalid(where, "min_expected", min_expected, "a finite number > 0");
  if (fitted_params < 0) throw_invalid(where, "fitted_params", fitted_params, "an integer >= 0");

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
    if (s < xs.front() && law.trimmed_below() && lattice) { obs.front() += 1; continue; }
    if (s > xs.back() && law.trimmed_above() && lattice) { obs.back() += 1; continue; }
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
    r.note = std::to_string(impossible) + " sample(s) fall on values the law gives probability 0 (first: " +
             format_value(first_impossible) + ")";
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
    std::size_t draws = 0;
    r.pvalue = exact_lr_pvalue(obs, ps, mass, count, draws);
    r.note = "too few samples for the chi-square approximation (fewer than two bins with expected count >= " +
             format_value(min_expected) + "): exact likelihood-ratio test on the unmerged values, Monte Carlo " +
             "p-value from " + std::to_string(draws) + " multinomial draws of the law";
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
