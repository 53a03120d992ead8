// The ZK16 baseline (DB23 §3, §7 and Fig. 11): isotropic mip grids and manual anisotropic filtering.
// The footprint is covered by n_s = min(ceil r, max_aniso) isotropic probes evenly spaced along its
// major axis, each of area P' / n_s, counted on the two mip levels around that area and blended
// ("zk16_linear": outputs, ZK16; "distributed": trial counts, DB23 eq. 10). Beyond max_aniso the minor
// axis is widened to major / max_aniso (the footprint grows: glints get larger, DB23 Fig. 11). Probes
// that land in the same cell read the same random numbers, as texture probes of a shader do, so the
// terms are not independent.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/aniso.hpp"

namespace glintlab::aniso {
namespace {

class Zk16Aniso final : public GridScheme {
 public:
  explicit Zk16Aniso(const LawParams& given) : ladder_(4.0, 1.0) {
    ParamReader reader("zk16_aniso", given);
    const double level_ratio = reader.number("level_ratio", 4.0);
    const double base_area = reader.number("base_area", 1.0);
    max_aniso_ = reader.number("max_aniso", 16.0);
    blend_ = reader.text("blend", "zk16_linear", {"zk16_linear", "distributed"});
    reader.finish();
    ladder_ = LevelLadder(level_ratio, base_area);
    blend_outputs_ = blend_ == "zk16_linear";
    if (!(max_aniso_ >= 1 && max_aniso_ <= 1024) || max_aniso_ != std::round(max_aniso_))
      throw_invalid("zk16_aniso", "max_aniso", max_aniso_, "an integer in [1, 1024]");
    params_ = {{"level_ratio", level_ratio}, {"base_area", base_area}, {"max_aniso", max_aniso_}, {"blend", blend_}};
  }

  std::string name() const override { return "zk16_aniso"; }
  LawParams params() const override { return params_; }
  bool independent_terms() const override { return false; }
  std::size_t max_terms() const override { return 2 * static_cast<std::size_t>(max_aniso_); }

  bool terms(const Shape& shape, double density, std::vector<Term>& out) const override {
    double minor = shape.minor;
    bool widened = false;
    if (shape.ratio > max_aniso_) {
      minor = shape.major / max_aniso_;
      widened = true;
    }
    // ceil with a relative tolerance, so that r = 2 computed as 2(1 + 1e-16) is 2 probes.
    const double probes = std::min(max_aniso_, std::max(1.0, std::ceil(shape.major / minor * (1 - 1e-12))));
    const double area = std::numbers::pi * shape.major * minor / probes;  // each probe's share
    const LevelBracket br = ladder_.bracket(area);
    const double c = std::cos(shape.angle), s = std::sin(shape.angle);
    const auto n = static_cast<int>(probes);
    const double side[2] = {std::sqrt(br.area_lo), std::sqrt(br.area_hi)};  // once per footprint, not per probe
    for (int q = 0; q < n; ++q) {
      const double offset = ((q + 0.5) / probes - 0.5) * 2 * shape.major;
      for (int lv = 0; lv < 2; ++lv) {
        Term t;
        const double cell = lv == 0 ? br.area_lo : br.area_hi;
        t.grid = {br.lo + lv, 0, 0};
        t.cell_minor = t.cell_major = side[lv];
        t.cell_area = cell;
        t.dx = offset * c;
        t.dy = offset * s;
        if (blend_outputs_) {
          t.weight = lv == 0 ? 1 - br.w_lod : br.w_lod;
          t.trials = density * cell;
          t.scale = area * t.weight / cell;
        } else {
          t.weight = lv == 0 ? 1 - br.w_area : br.w_area;
          t.trials = t.weight * density * cell;
        }
        out.push_back(t);
      }
    }
    return widened;
  }

 private:
  LevelLadder ladder_;
  double max_aniso_ = 16;
  std::string blend_;
  bool blend_outputs_ = true;  // blend_ == "zk16_linear", compared once rather than per term
  LawParams params_;
};

const bool registered =
    register_grid_scheme({"zk16_aniso",
                          "ZK16 baseline: min(ceil r, 16) isotropic mip probes along the major axis, widened beyond",
                          [](const LawParams& params) { return std::make_unique<Zk16Aniso>(params); },
                          // ZK16 evaluate their own hybrid law (DB23 eq. 15) on these probes; DB23 §7 compares them so.
                          {.native_law = "zk16"}});

}  // namespace
}  // namespace glintlab::aniso
