#include "glintlab/step_inversion.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "glintlab/normal.hpp"

namespace glintlab {

StepInversion::StepInversion(std::vector<double> thresholds, std::vector<double> guards, double base,
                             bool exact_below, bool exact_above)
    : t_(std::move(thresholds)), guard_(std::move(guards)), base_(base), exact_below_(exact_below),
      exact_above_(exact_above) {
  if (t_.size() != guard_.size()) throw std::logic_error("StepInversion: one guard per threshold");
  if (!std::is_sorted(t_.begin(), t_.end())) throw std::logic_error("StepInversion: unsorted thresholds");
  if (t_.size() > (1u << 24)) throw std::logic_error("StepInversion: too many thresholds");
  std::size_t size = 1024;
  while (size < 16 * t_.size() && size < (std::size_t{1} << 22)) size *= 2;
  cells_scale_ = static_cast<double>(size);
  cell_.assign(size, 0);
  // Count thresholds at or below each cell's left edge; then void the cells a band touches.
  std::size_t i = 0;
  for (std::size_t g = 0; g < size; ++g) {
    const double left = static_cast<double>(g) / cells_scale_;
    while (i < t_.size() && t_[i] <= left) ++i;
    cell_[g] = static_cast<std::int32_t>(i);
    if ((i == 0 && !exact_below_) || (i == t_.size() && !exact_above_)) cell_[g] = -1;
  }
  for (std::size_t j = 0; j < t_.size(); ++j) {
    const double lo = std::max(0.0, t_[j] - guard_[j]) * cells_scale_;
    const double hi = std::min(1.0, t_[j] + guard_[j]) * cells_scale_;
    const std::size_t a = static_cast<std::size_t>(std::floor(lo));
    const std::size_t b = std::min(size - 1, static_cast<std::size_t>(std::floor(hi)));
    for (std::size_t g = a; g <= b && g < size; ++g) cell_[g] = -1;
  }
  // A threshold on a cell's left edge belongs to that cell (t <= left counts it; the band covers
  // the cell to the left through floor(lo)), so every kept cell has one value throughout.
}

double StepInversion::search(double u) const {
  const std::size_t count = t_.size();
  const std::size_t i = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), u) - t_.begin());
  if (i > 0 ? (u - t_[i - 1] < guard_[i - 1]) : !exact_below_) return -1.0;
  if (i < count ? (t_[i] - u <= guard_[i]) : !exact_above_) return -1.0;
  return base_ + static_cast<double>(i);
}

double StepInversion::gaussian_guard(double t, double z, double s, double slope, double magnitude) {
  constexpr double kEps = 2.220446049250313e-16;
  const double density = std::exp(-0.5 * z * z) * 0.3989422804014327;
  // Error of v in units of v, turned into an error of z (divide by s h'), then of u (times phi).
  const double dz = 8 * kEps * (magnitude + 1) / (s * slope) + 1e-15 * (std::abs(z) + 1);
  const double dt = 64 * kEps + 1e-14 * std::min(t, 1 - t);  // Phi at t, near 0 and near 1
  return 1e3 * (density * dz + dt);
}

std::optional<StepInversion> floor_gaussian_steps(double mean, double sd, double shift, double top,
                                                  std::size_t max_steps) {
  if (!(sd > 0) || !(top >= 0)) return std::nullopt;
  // Beyond 8.5 sd the law continues with probability < 1e-16: left to direct evaluation.
  const double lo = std::clamp(std::floor(mean + shift - 8.5 * sd), 0.0, top);
  const double hi = std::clamp(std::ceil(mean + shift + 8.5 * sd), 0.0, top);
  if (hi - lo > static_cast<double>(max_steps)) return std::nullopt;
  const double magnitude = std::abs(mean) + std::abs(shift) + 9 * sd;
  std::vector<double> t, guard;
  double covered = 0;
  for (double j = lo + 1; j <= hi; j += 1) {  // v >= j  iff  z >= (j - shift - mean) / sd
    const double z = (j - shift - mean) / sd;
    t.push_back(normal::cdf(z));
    guard.push_back(StepInversion::gaussian_guard(t.back(), z, sd, 1.0, magnitude));
    covered += 2 * guard.back();
  }
  if (covered > 1e-3) return std::nullopt;
  return StepInversion(std::move(t), std::move(guard), lo, lo == 0, hi == top);
}

}  // namespace glintlab
