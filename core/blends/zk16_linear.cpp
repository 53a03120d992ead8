// Blend "zk16_linear": ZK16 blends the *outputs* of the two levels with the LOD weight w,
//   K = P [(1 - w) b(N A_lo, p) / A_lo + w b(N A_hi, p) / A_hi].
// The mean is N P p for any w; the variance, for a binomial inner law, is N p (1 - p) P^2
// [(1 - w)^2 / A_lo + w^2 / A_hi]: a fraction P [(1 - w)^2 / A_lo + w^2 / A_hi] of the ground truth's
// N P p (1 - p) (0.625 at w = 1/2 with ratio 4). Values form a lattice of non-integers: twice the
// glints at half the intensity, DB23's ghosting (Fig. 2a, 4b).
#include "glintlab/counting/blend.hpp"

namespace glintlab {
namespace {

class Zk16Linear final : public RowwiseRule<Zk16Linear> {
 public:
  std::string name() const override { return "zk16_linear"; }
  std::array<double, 2> trials(double density, double, const LevelBracket& b) const override {
    return {density * b.area_lo, density * b.area_hi};
  }
  double combine(double area, const LevelBracket& b, double k_lo, double k_hi,
                 std::array<FacetStream, 2>&) const override {
    return area * ((1.0 - b.w_lod) * k_lo / b.area_lo + b.w_lod * k_hi / b.area_hi);
  }
  Distribution combine_pmf(double area, const LevelBracket& b, const Distribution& lo, const Distribution& hi,
                           std::size_t max_support) const override {
    return scaled_sum(lo, area * (1.0 - b.w_lod) / b.area_lo, hi, area * b.w_lod / b.area_hi, true, max_support,
                      "blended_law('zk16_linear').pmf");
  }
  // The deficit of the file comment: each level's variance N A_l p (1 - p) scaled by (P w_l / A_l)^2.
  double variance_ratio(double area, const LevelBracket& b) const override {
    const double w = b.w_lod;
    return area * ((1.0 - w) * (1.0 - w) / b.area_lo + w * w / b.area_hi);
  }
};

const bool registered = register_parameterless_blend<Zk16Linear>(
    "zk16_linear", "ZK16 output blend: P[(1-w) b_lo/A_lo + w b_hi/A_hi] (right mean, variance deficit, ghosting)");

}  // namespace
}  // namespace glintlab
