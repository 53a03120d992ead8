// Blend "nearest": WB16's stepped grid scale. One level, the nearer in LOD (round(w), w = 0.5 goes
// up), its count rescaled to the footprint: K = (P / A_l) · b(N A_l, p). Right mean, the variance of
// the level's cell rescaled, and a pop each time the rounded level changes.
#include "glintlab/counting/blend.hpp"

namespace glintlab {
namespace {

class Nearest final : public RowwiseRule<Nearest> {
 public:
  std::string name() const override { return "nearest"; }
  static bool upper(const LevelBracket& b) { return b.w_lod >= 0.5; }
  std::array<double, 2> trials(double density, double, const LevelBracket& b) const override {
    // Selects, not a branch: per-sample footprints make round(w) a coin flip for the branch predictor.
    const bool up = upper(b);
    return {select(up, 0.0, density * b.area_lo), select(up, density * b.area_hi, 0.0)};
  }
  double combine(double area, const LevelBracket& b, double k_lo, double k_hi,
                 std::array<FacetStream, 2>&) const override {
    const bool up = upper(b);  // selects of the operands, not a branch (as trials())
    return area / select(up, b.area_hi, b.area_lo) * select(up, k_hi, k_lo);
  }
  Distribution combine_pmf(double area, const LevelBracket& b, const Distribution& lo, const Distribution& hi,
                           std::size_t max_support) const override {
    // The level not drawn is a point mass at 0.
    return scaled_sum(lo, area / b.area_lo, hi, area / b.area_hi, true, max_support, "blended_law('nearest').pmf");
  }
  // (P / A_l)^2 N A_l p (1 - p) over N P p (1 - p): P / A_l, above 1 below the level and below 1 above it.
  double variance_ratio(double area, const LevelBracket& b) const override {
    return area / (upper(b) ? b.area_hi : b.area_lo);
  }
};

const bool registered = register_parameterless_blend<Nearest>(
    "nearest", "one level, round(w), count rescaled by P / A_l (WB16 stepping: pops at level changes)");

}  // namespace
}  // namespace glintlab
