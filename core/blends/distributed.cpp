// Blend "distributed": DB23 eq. 10 blends the *parameters*: the footprint's area is split between
// the levels, P = w̲ A_lo + w̄ A_hi with w̄ = (P - A_lo) / (A_hi - A_lo), and
//   K = b(w̲ N A_lo, p) + b(w̄ N A_hi, p).
// The binomial is additive, so with integer trial counts K ~ Binomial(N P, p) exactly (DB23 Fig. 4c).
// Non-integer trial counts go to the inner law unchanged (its own rule; for the exact binomial,
// Binomial(floor n, p) + Bernoulli(frac(n) p) per level: the mean stays N P p and the variance grows
// by at most p^2/2 over Binomial(N P, p), see docs).
#include "glintlab/counting/blend.hpp"

namespace glintlab {
namespace {

class Distributed final : public RowwiseRule<Distributed> {
 public:
  std::string name() const override { return "distributed"; }
  bool reads_lod_weight() const override { return false; }  // DB23 eq. 10 weighs by area
  std::array<double, 2> trials(double density, double, const LevelBracket& b) const override {
    return {(1.0 - b.w_area) * density * b.area_lo, b.w_area * density * b.area_hi};
  }
  double combine(double, const LevelBracket&, double k_lo, double k_hi, std::array<FacetStream, 2>&) const override {
    return k_lo + k_hi;
  }
  bool integer_output() const override { return true; }
  Distribution combine_pmf(double, const LevelBracket&, const Distribution& lo, const Distribution& hi,
                           std::size_t max_support) const override {
    return convolve(lo, hi, max_support, "blended_law('distributed').pmf");
  }
  // Additivity: Binomial(N P, p) itself with integer trial counts (non-integer ones add at most
  // p^2 / 2 to the variance, which the ratio does not model).
  double variance_ratio(double, const LevelBracket&) const override { return 1.0; }
};

const bool registered = register_parameterless_blend<Distributed>(
    "distributed", "DB23 eq. 10: b(w_lo N A_lo, p) + b(w_hi N A_hi, p), area weights (Binomial(NP, p) exactly)");

}  // namespace
}  // namespace glintlab
