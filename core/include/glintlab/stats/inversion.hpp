// Inversion by sequential search for lattice laws with a small mean (< 30) whose pmf follows
// f(k) = f(k - 1) (a / k - s) from f(0): the binomial (a = (m + 1) p/q, s = p/q) and the Poisson
// (a = lambda, s = 0). K is the smallest k with u <= c_k, c_k = c_{k-1} + f(k).
//
// Two paths give bit-identical results: an on-the-fly search (no setup, for one-off parameters)
// and a tabulated one (the same c_k, computed by the same operations in the same order, plus a
// guide table of Chen & Asau (1974), so a draw costs O(1) instead of O(mean) steps with a division
// each). The search is cut at `bound` (mean + 15 sd + 30: tail mass below 1e-40) and restarted
// beyond it with a fresh uniform, so that rounding in c_k can never make it walk to n = 1e15.
#pragma once

#include <cstdint>
#include <vector>

#include "glintlab/base/rng.hpp"

namespace glintlab {

class SmallMeanInversion {
 public:
  SmallMeanInversion() = default;
  SmallMeanInversion(double f0, double a, double s, double bound, bool tabulate);

  template <class Rng>  // CounterRng, or binomial::PrefetchedRng (the same numbers)
  double operator()(Rng& rng) const {
    if (!cum_.empty()) return tabulated(rng);
    for (;;) {
      const double u = rng.uniform();
      double f = f0_, c = f0_, k = 0;
      while (u > c) {
        k += 1;
        if (k > bound_) break;
        f *= a_ / k - s_;
        c += f;
      }
      if (k <= bound_) return k;
    }
  }

 private:
  template <class Rng>
  double tabulated(Rng& rng) const {
    const std::size_t last = cum_.size() - 1;
    for (;;) {
      const double u = rng.uniform();
      // guide_[j] = first k with c_k >= j / G; u >= j / G exactly (G is a power of two).
      std::size_t k = guide_[static_cast<std::size_t>(u * guide_scale_)];
      while (k <= last && cum_[k] < u) ++k;
      if (k <= last) return static_cast<double>(k);
    }
  }

  double f0_ = 1.0, a_ = 0.0, s_ = 0.0, bound_ = 0.0;
  std::vector<double> cum_;
  std::vector<std::uint32_t> guide_;
  double guide_scale_ = 0.0;
};

}  // namespace glintlab
