#include "glintlab/chi2.hpp"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <limits>

#include "glintlab/errors.hpp"

namespace glintlab {

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

  // Expected counts, normalized by the law's mass (a trimmed law holds 1 - 1e-14).
  const double total = static_cast<double>(count), mass = law.total_mass();
  std::size_t start = 0;
  double acc_e = 0.0, acc_o = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    acc_e += total * ps[i] / mass;
    acc_o += obs[i];
    if (acc_e >= min_expected) {
      r.lower.push_back(xs[start]);
      r.upper.push_back(xs[i]);
      r.expected.push_back(acc_e);
      r.observed.push_back(acc_o);
      start = i + 1;
      acc_e = acc_o = 0.0;
    }
  }
  if (start < m) {  // remainder below min_expected joins the last bin
    if (r.expected.empty()) {
      r.lower.push_back(xs[start]);
      r.upper.push_back(xs.back());
      r.expected.push_back(acc_e);
      r.observed.push_back(acc_o);
    } else {
      r.upper.back() = xs.back();
      r.expected.back() += acc_e;
      r.observed.back() += acc_o;
    }
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
  if (r.dof < 1) {
    r.dof = 0;
    r.pvalue = 1.0;
    r.note = "fewer than two bins with expected count >= " + format_value(min_expected) +
             ": the test has no power (use more samples)";
    return r;
  }
  const boost::math::chi_squared_distribution<double> chi2(r.dof);
  r.pvalue = boost::math::cdf(boost::math::complement(chi2, r.statistic));
  return r;
}

double sidak_alpha(double alpha, int tests) {
  if (!(alpha > 0.0 && alpha < 1.0)) throw_invalid("sidak_alpha", "alpha", alpha, "a number in (0, 1)");
  if (tests < 1) throw_invalid("sidak_alpha", "tests", tests, "an integer >= 1");
  return -std::expm1(std::log1p(-alpha) / tests);
}

}  // namespace glintlab
