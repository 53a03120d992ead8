// Table inversion of a monotone step function of one uniform, exact by construction.
//
// Many constant-time laws map a uniform u through Phi^-1 and a floor (gated: floor(mu + sd z)); at a
// fixed (n, p) the result is a step function of u whose steps sit at analytic thresholds t_i
// (Phi((j - mu)/sd)). A batch of samples at one (n, p) can find its step with one table load instead
// of evaluating logs, square roots and rational functions per sample (the cost a shader pays once
// per pixel; a Monte Carlo study pays it 1e7 times): [0, 1) is cut into 2^b equal cells (at least
// 16 per threshold, so u * 2^b is exact); a cell that no threshold or guard band touches stores its
// value, the others (a few percent) fall back to a binary search.
//
// Exactness: the analytic t_i and the law's floating-point evaluation may disagree by a few ulps
// about which side of a step a u lies on. Every threshold therefore carries a guard band, wider
// than that disagreement by a factor >= 1e3; a u inside a band (or beyond the table's ends when the
// law continues there) gets no answer and the caller evaluates the law directly. So a table lookup
// returns what evaluate() returns, bit for bit (tests/cpp/test_law.cpp compares 1e7 draws).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace glintlab {

class StepInversion {
 public:
  // Thresholds ascending. For u outside every guard band:
  //   value(u) = base + #{i : thresholds[i] <= u},
  // and u below thresholds[0] (above the last) is answered only if exact_below (exact_above).
  StepInversion(std::vector<double> thresholds, std::vector<double> guards, double base,
                bool exact_below, bool exact_above);

  // The step's value, or a negative number when the caller must evaluate directly.
  double operator()(double u) const {
    std::size_t g = static_cast<std::size_t>(u * cells_scale_);
    if (g >= cell_.size()) g = cell_.size() - 1;
    const std::int32_t v = cell_[g];
    return v >= 0 ? base_ + static_cast<double>(v) : search(u);
  }

  std::size_t size() const { return t_.size(); }

  // The guard for a threshold t at standard-normal quantile z of a law whose step variable is
  // v = a + s h(z) (h' >= slope > 0 near z), |v| <= magnitude: covers the rounding of v (a few ulps
  // of magnitude), of Phi^-1 (relative 1e-15) and of Phi at t (absolute and relative), times 1e3.
  static double gaussian_guard(double t, double z, double s, double slope, double magnitude);

 private:
  double search(double u) const;
  std::vector<double> t_, guard_;
  std::vector<std::int32_t> cell_;  // #{t <= u} for every u of the cell, or -1: search
  double cells_scale_;
  double base_;
  bool exact_below_, exact_above_;
};

// The steps of v(u) = clamp(floor(mean + sd Phi^-1(u) + shift), 0, top) (sd > 0), or nothing when
// they are more than max_steps or their guard bands would cover more than 1e-3 of [0, 1].
std::optional<StepInversion> floor_gaussian_steps(double mean, double sd, double shift, double top,
                                                  std::size_t max_steps = 1 << 16);

}  // namespace glintlab
