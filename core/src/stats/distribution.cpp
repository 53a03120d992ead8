#include "glintlab/stats/distribution.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <stdexcept>
#include <string>

#include "glintlab/base/errors.hpp"

namespace glintlab {

Distribution::Distribution(std::vector<double> support, std::vector<double> probs, bool normalize)
    : support_(std::move(support)), probs_(std::move(probs)) {
  constexpr std::string_view where = "Distribution";
  if (support_.size() != probs_.size())
    throw_invalid_message("Distribution: support has " + std::to_string(support_.size()) + " points but probs has " +
                          std::to_string(probs_.size()));
  if (support_.empty()) throw_invalid_message("Distribution: support is empty");
  double sum = 0.0;
  for (std::size_t i = 0; i < support_.size(); ++i) {
    if (!std::isfinite(support_[i]))
      throw_invalid(where, indexed_name("support", i, true), support_[i], "a finite number");
    if (i > 0 && !(support_[i] > support_[i - 1]))
      throw_invalid(where, indexed_name("support", i, true), support_[i], "strictly increasing support values");
    if (!(probs_[i] >= 0.0) || !std::isfinite(probs_[i]))
      throw_invalid(where, indexed_name("probs", i, true), probs_[i], "a finite probability >= 0");
    sum += probs_[i];
  }
  if (normalize) {
    if (!(sum > 0.0)) throw_invalid(where, "sum(probs)", sum, "a positive total to normalize");
    for (double& q : probs_) q /= sum;
  } else if (std::abs(sum - 1.0) > 1e-9) {
    throw_invalid(where, "sum(probs)", sum, "1 within 1e-9 (pass normalize=true to rescale)");
  }
  finish();
}

void Distribution::finish() {
  // Moments about a shift (the most probable point): support values reach 1e15, where sum p x
  // would lose ~1e-16 x per term (a mean off by tens); x - shift is exact for integer supports.
  std::size_t top = 0;
  for (std::size_t i = 1; i < probs_.size(); ++i)
    if (probs_[i] > probs_[top]) top = i;
  const double shift = support_[top];
  double mass = 0.0, c = 0.0, m1 = 0.0;
  for (std::size_t i = 0; i < probs_.size(); ++i) {
    const double y = probs_[i] - c, t = mass + y;  // compensated (Kahan) mass
    c = (t - mass) - y;
    mass = t;
    m1 += probs_[i] * (support_[i] - shift);
  }
  const double dm = m1 / mass;  // mean - shift
  double v = 0.0;
  for (std::size_t i = 0; i < probs_.size(); ++i) {
    const double d = (support_[i] - shift) - dm;
    v += probs_[i] * d * d;
  }
  mass_ = mass;
  mean_ = shift + dm;
  var_ = v / mass;
}

double Distribution::cdf(double x) const {
  double s = 0.0;
  for (std::size_t i = 0; i < support_.size() && support_[i] <= x; ++i) s += probs_[i];
  return std::min(s, 1.0);
}

Distribution Distribution::from_log_concave(const std::function<double(double)>& log_pmf, double lo, double hi,
                                            double mode, std::size_t max_support, std::string_view where) {
  const double half = kTrimMass / 2;
  mode = std::clamp(std::floor(mode), lo, hi);
  std::deque<double> ks{mode}, ps{std::exp(log_pmf(mode))};
  auto too_large = [&] {
    throw_invalid_message(std::string(where) + ": the distribution needs more than " + std::to_string(max_support) +
                          " support points to hold all but 1e-14 of its mass; use the cdf/sf "
                          "functions for such parameters or raise max_support");
  };
  // Walks one side; returns whether a tail with positive mass was left out. With the ratio
  // r = pmf(k)/pmf(k -+ 1) non-increasing away from the mode, the rest is at most pmf(k) r / (1 - r).
  auto walk = [&](int dir) {
    double prev = ps.front();
    if (dir > 0) prev = ps.back();
    for (double k = mode + dir; dir > 0 ? k <= hi : k >= lo; k += dir) {
      const double lf = log_pmf(k);
      if (lf == -std::numeric_limits<double>::infinity()) return false;  // impossible from here on
      const double f = std::exp(lf);
      if (dir > 0) {
        ks.push_back(k);
        ps.push_back(f);
      } else {
        ks.push_front(k);
        ps.push_front(f);
      }
      if (ks.size() > max_support) too_large();
      if (f == 0.0) return true;  // underflow: the rest is below 1e-308 but not zero
      const double r = prev > 0 ? f / prev : 0.0;
      if (r < 1.0 && f * r / (1.0 - r) <= half) return dir > 0 ? k < hi : k > lo;
      prev = f;
    }
    return false;  // reached the end of the support
  };
  const bool above = walk(+1), below = walk(-1);
  // Drop zeros (underflowed or impossible) at the ends.
  while (ps.size() > 1 && ps.back() == 0.0) {
    ps.pop_back();
    ks.pop_back();
  }
  while (ps.size() > 1 && ps.front() == 0.0) {
    ps.pop_front();
    ks.pop_front();
  }
  Distribution d;
  d.trimmed_below_ = below;
  d.trimmed_above_ = above;
  d.support_.assign(ks.begin(), ks.end());
  d.probs_.assign(ps.begin(), ps.end());
  d.finish();
  return d;
}

Distribution Distribution::with_trimmed_tails(std::vector<double> support, std::vector<double> probs,
                                              bool trimmed_below, bool trimmed_above) {
  Distribution d(std::move(support), std::move(probs));
  d.trimmed_below_ = trimmed_below;
  d.trimmed_above_ = trimmed_above;
  return d;
}

Distribution Distribution::empirical(const double* samples, std::size_t count) {
  if (count == 0) throw_invalid_message("empirical distribution: samples is empty");
  std::vector<double> v(samples, samples + count);
  for (std::size_t i = 0; i < count; ++i)
    if (!std::isfinite(v[i]))
      throw_invalid("empirical distribution", indexed_name("samples", i, true), v[i], "finite samples");
  std::sort(v.begin(), v.end());
  Distribution d;
  for (std::size_t i = 0; i < count;) {
    std::size_t j = i;
    while (j < count && v[j] == v[i]) ++j;
    d.support_.push_back(v[i]);
    d.probs_.push_back(static_cast<double>(j - i) / static_cast<double>(count));
    i = j;
  }
  d.finish();
  return d;
}

Distribution scaled_sum(const Distribution& x, double a, const Distribution& y, double b, bool round_half_up,
                        std::size_t max_support, std::string_view where) {
  if (!(a >= 0.0 && b >= 0.0 && std::isfinite(a) && std::isfinite(b)))
    throw std::logic_error("scaled_sum: scales must be finite and >= 0");
  const auto bin = [&](double v) {
    if (round_half_up) return std::floor(v + 0.5);
    if (v != std::floor(v)) throw std::logic_error("scaled_sum: a non-integer value without rounding");
    return v;
  };
  // Non-negative scales keep the extremes at the ends of the supports.
  const double lo = bin(a * x.support().front() + b * y.support().front());
  const double hi = bin(a * x.support().back() + b * y.support().back());
  if (hi - lo + 1 > static_cast<double>(max_support))
    throw_invalid_message(std::string(where) +
                          ": the law needs more than max_support = " + std::to_string(max_support) + " support points");
  std::vector<double> probs(static_cast<std::size_t>(hi - lo) + 1, 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double xi = a * x.support()[i], pi = x.probs()[i];
    for (std::size_t k = 0; k < y.size(); ++k)
      probs[static_cast<std::size_t>(bin(xi + b * y.support()[k]) - lo)] += pi * y.probs()[k];
  }
  // Keep the support tight: drop empty bins at the ends, and inside only when rounding leaves gaps
  // (a lattice of scaled values); integer convolutions keep every point between the ends.
  std::vector<double> support, kept;
  for (std::size_t i = 0; i < probs.size(); ++i) {
    if (probs[i] == 0.0 && (round_half_up || support.empty())) continue;
    support.push_back(lo + static_cast<double>(i));
    kept.push_back(probs[i]);
  }
  while (kept.size() > 1 && kept.back() == 0.0) {
    kept.pop_back();
    support.pop_back();
  }
  return Distribution::with_trimmed_tails(std::move(support), std::move(kept), x.trimmed_below() || y.trimmed_below(),
                                          x.trimmed_above() || y.trimmed_above());
}

}  // namespace glintlab
