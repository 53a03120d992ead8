// A discrete distribution as a value: strictly increasing support points and their probabilities.
// Laws with integer counts use integer-valued support; laws with real-valued outputs use the points
// (or bin centres) they state. Exact laws are trimmed: tails are dropped while the kept mass stays
// within `kTrimMass` of 1 (so probabilities sum to 1 within 1e-14 plus rounding).
#pragma once

#include <cstddef>
#include <functional>
#include <string_view>
#include <vector>

namespace glintlab {

inline constexpr double kTrimMass = 1e-14;
inline constexpr std::size_t kDefaultMaxSupport = 50'000'000;

class Distribution {
 public:
  Distribution() = default;
  // Validates: equal lengths, non-empty, finite strictly increasing support, finite probs >= 0
  // summing to 1 within 1e-9 (or any positive sum when `normalize`, which then rescales).
  Distribution(std::vector<double> support, std::vector<double> probs, bool normalize = false);

  const std::vector<double>& support() const { return support_; }
  const std::vector<double>& probs() const { return probs_; }
  std::size_t size() const { return support_.size(); }
  double mean() const { return mean_; }
  double var() const { return var_; }
  double total_mass() const { return mass_; }
  // True when a tail beyond the first (last) support point was trimmed away: values there have a
  // positive (below 1e-14) probability that this value does not list.
  bool trimmed_below() const { return trimmed_below_; }
  bool trimmed_above() const { return trimmed_above_; }
  // Cumulative probability of the support points <= x.
  double cdf(double x) const;

  // The law on the integers of [lo, hi] whose log pmf is `log_pmf(k)` (-inf where the law is
  // impossible; log-concave: pmf(k+1)/pmf(k) non-increasing, true for binomial, Poisson and their
  // convolutions). Walks outward from `mode` and stops on each side once a geometric bound on the
  // remaining tail is below kTrimMass / 2 (a trimmed tail), or at lo / hi / an impossible value
  // (nothing trimmed). Throws std::invalid_argument naming `where` beyond `max_support` points.
  static Distribution from_log_concave(const std::function<double(double)>& log_pmf, double lo, double hi, double mode,
                                       std::size_t max_support, std::string_view where);

  // A law given on part of its support, the rest (below the first / above the last point, total
  // below 1e-14) trimmed away: probs sum to 1 within 1e-9 as in the constructor.
  static Distribution with_trimmed_tails(std::vector<double> support, std::vector<double> probs, bool trimmed_below,
                                         bool trimmed_above);

  // The empirical law of samples (each distinct value with its frequency). Samples must be finite.
  static Distribution empirical(const double* samples, std::size_t count);

 private:
  void finish();
  std::vector<double> support_, probs_;
  double mean_ = 0.0, var_ = 0.0, mass_ = 0.0;
  bool trimmed_below_ = false, trimmed_above_ = false;
};

// The law of a·X + b·Y for independent X ~ x and Y ~ y (a, b >= 0), on integer bins: values are
// rounded half up to integers when `round_half_up`, and must already be integers otherwise
// (std::logic_error if not). With a = b = 1 on integer supports this is the convolution. Cost:
// x.size() · y.size(). Throws std::invalid_argument naming `where` when the result would need
// more than `max_support` points. Trimmed-tail flags are inherited.
Distribution scaled_sum(const Distribution& x, double a, const Distribution& y, double b, bool round_half_up,
                        std::size_t max_support, std::string_view where);
// The law of X + Y for independent X ~ x, Y ~ y on integer supports.
inline Distribution convolve(const Distribution& x, const Distribution& y, std::size_t max_support,
                             std::string_view where) {
  return scaled_sum(x, 1.0, y, 1.0, false, max_support, where);
}

}  // namespace glintlab
