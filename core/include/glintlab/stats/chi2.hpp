// Pearson chi-square goodness of fit of samples against an exact discrete law.
//
// Bins: the law's support points in order, merged greedily from the left until each merged bin
// expects at least `min_expected` samples; a remainder below that joins the last bin. The first and
// last bins also hold the law's trimmed tails (Distribution::trimmed_below/above), so integer samples
// beyond a trimmed end count there. Any other sample that is not a support point has probability
// zero under the law: the test then fails outright (statistic +inf, p-value 0, and a note).
// dof = bins - 1 - fitted_params; p-value = P(chi2_dof >= statistic) from Boost.Math.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "glintlab/stats/distribution.hpp"

namespace glintlab {

struct Chi2Result {
  double statistic = 0.0;
  int dof = 0;
  double pvalue = 1.0;
  std::size_t samples = 0;
  // Merged bins: [lower, upper] support values, observed and expected counts; for failure plots.
  std::vector<double> lower, upper, observed, expected;
  std::string note;  // why the test is degenerate or failed outright; empty otherwise
  // The p-value's resolution: 0 when it is computed (Boost.Math's tail, an exact enumeration, a bound),
  // 1 / (1 + draws) when it is a Monte Carlo estimate (it can be no smaller than that).
  double resolution = 0.0;
};

// `alpha` (0: not given) is the level the p-value will be compared with. The small-sample exact test
// (fewer than two merged bins) then never leaves the decision p <= alpha to a p-value coarser than
// alpha: it enumerates every outcome when they are few, else uses the method-of-types bound or draws
// more Monte Carlo samples until the decision is clear (docs/math/metrics.md#metric-chi2-test).
Chi2Result chi2_test(const double* samples, std::size_t count, const Distribution& law, double min_expected = 5.0,
                     int fitted_params = 0, double alpha = 0.0);

// The merge rule of chi2_test on cells already in order: cells are merged greedily from the first
// until each merged bin expects at least `min_expected`; a remainder below that joins the last bin.
// Returns the index of the first cell of each merged bin (empty when m == 0). The direction-sampler
// harness (sampler_test.hpp) merges its spatially ordered bins with the same rule.
std::vector<std::size_t> merge_starts(const double* expected, std::size_t m, double min_expected);

// Per-test significance that keeps the family-wise false-failure rate at `alpha` over `tests`
// independent tests (Šidák): 1 - (1 - alpha)^(1/tests).
double sidak_alpha(double alpha, int tests);

}  // namespace glintlab
