#include "glintlab/distribution.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <stdexcept>
#include <string>

#include "glintlab/errors.hpp"

namespace glintlab {

Distribution::Distribution(std::vector<double> support, std::vector<double> probs, bool normalize)
    : support_(std::move(support)), probs_(std::move(probs)) {
  constexpr std::string_view where = "Distribution";
  if (support_.size() != probs_.size())
    throw std::invalid_argument("Distribution: support has " + std::to_string(support_.size()) +
                                " points but probs has " + std::to_string(probs_.size()));
  if (support_.empty()) throw std::invalid_argument("Distribution: support is empty");
  double sum = 0.0;
  for (std::size_t i = 0; i < support_.size(); ++i) {
    if (!std::isfinite(support_[i]))
      throw_invalid(where, indexed_name("support", i, true), support_[i], "a finite number");
    if (i > 0 && !(support_[i] > support_[i - 1]))
      throw_invalid(where, indexed_name("support", i, true), support_[i],
                    "strictly increasing support values");
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
  // Compensated sums; the variance in a second pass around the mean (support values reach 1e15).
  double mass = 0.0, c = 0.0;
  for (double q : probs_) {
    double y = q - c, t = mass + y;
    c = (t - mass) - y;
    mass = t;
  }
  double m = 0.0;
  for (std::size_t i = 0; i < probs_.size(); ++i) m += probs_[i] * support_[i];
  m /= mass;
  double v = 0.0;
  for (std::size_t i = 0; i < probs_.size(); ++i) {
    const double d = support_[i] - m;
    v += probs_[i] * d * d;
  }
  mass_ = mass;
  mean_ = m;
  var_ = v / mass;
}

double Distribution::cdf(double x) const {
  double s = 0.0;
  for (std::size_t i = 0; i < support_.size() && support_[i] <= x; ++i) s += probs_[i];
  return std::min(s, 1.0);
}

Distribution Distribution::from_log_concave(const std::function<double(double)>& pmf, double lo,
                                            double hi, double mode, std::size_t max_support,
                                            std::string_view where) {
  const double half = kTrimMass / 2;
  mode = std::clamp(std::floor(mode), lo, hi);
  std::deque<double> ks{mode}, ps{pmf(mode)};
  auto too_large = [&] {
    throw std::invalid_argument(std::string(where) + ": the distribution needs more than " +
                                std::to_string(max_support) +
                                " support points to hold all but 1e-14 of its mass; use the cdf/sf "
                                "functions for such parameters or raise max_support");
  };
  // Right tail: with r = pmf(k)/pmf(k-1) non-increasing, sum_{j>k} pmf(j) <= pmf(k) r / (1 - r).
  for (double k = mode + 1, prev = ps.back(); k <= hi; k += 1) {
    const double f = pmf(k);
    ks.push_back(k);
    ps.push_back(f);
    if (ks.size() > max_support) too_large();
    const double r = prev > 0 ? f / prev : 0.0;
    if (f == 0.0 || (r < 1.0 && f * r / (1.0 - r) <= half)) break;
    prev = f;
  }
  for (double k = mode - 1, prev = ps.front(); k >= lo; k -= 1) {
    const double f = pmf(k);
    ks.push_front(k);
    ps.push_front(f);
    if (ks.size() > max_support) too_large();
    const double r = prev > 0 ? f / prev : 0.0;
    if (f == 0.0 || (r < 1.0 && f * r / (1.0 - r) <= half)) break;
    prev = f;
  }
  // Drop exact zeros at the ends (e.g. p = 0 puts all mass on k = 0).
  while (ps.size() > 1 && ps.back() == 0.0) { ps.pop_back(); ks.pop_back(); }
  while (ps.size() > 1 && ps.front() == 0.0) { ps.pop_front(); ks.pop_front(); }
  Distribution d;
  d.trimmed_below_ = ks.front() > lo && ps.front() > 0.0;
  d.trimmed_above_ = ks.back() < hi && ps.back() > 0.0;
  d.support_.assign(ks.begin(), ks.end());
  d.probs_.assign(ps.begin(), ps.end());
  d.finish();
  return d;
}

Distribution Distribution::empirical(const double* samples, std::size_t count) {
  if (count == 0) throw std::invalid_argument("empirical distribution: samples is empty");
  std::vector<double> v(samples, samples + count);
  for (std::size_t i = 0; i < count; ++i)
    if (!std::isfinite(v[i])) throw_invalid("empirical distribution", indexed_name("samples", i, true), v[i], "finite samples");
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

}  // namespace glintlab
