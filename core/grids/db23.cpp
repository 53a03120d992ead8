// DB23's anisotropic virtual grids (§5.2 trilinear, §6.1 tetrahedral): see aniso.hpp for how the
// grids are laid out. Here: which grids a footprint's count is distributed over, and with what weights.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/aniso.hpp"

namespace glintlab::aniso {
namespace {

// A vertex of the (φ, r) plane of a cell: its ratio level, orientation index, position in the cell's
// plane coordinates and an ordering key (ratio face, then angle) shared by neighbouring cells, so the
// prisms' diagonal cuts agree across every shared face (weights continuous across cells).
struct PlaneVertex {
  int ratio;
  std::int64_t orientation;
  double x, y;
  int key;
};

class Db23Grids final : public GridScheme {
 public:
  Db23Grids(bool tetrahedral, const LawParams& given) : tetrahedral_(tetrahedral), ladder_(4.0, 1.0) {
    const std::string name = tetrahedral ? "db23_tetrahedral" : "db23_trilinear";
    ParamReader reader(name, given);
    const double level_ratio = reader.number("level_ratio", 4.0);
    const double base_area = reader.number("base_area", 1.0);
    scale_weights_ = reader.text("scale_weights", "area", {"area", "log"});
    ratio_weights_ = reader.text("ratio_weights", "linear", {"linear", "log"});
    step_deg_ = reader.number("orientation_step", 22.5);
    max_ratio_ = reader.number("max_ratio", 1048576.0);
    reader.finish();
    ladder_ = LevelLadder(level_ratio, base_area);
    const double per_half_turn = 180.0 / step_deg_;
    if (!(step_deg_ > 0) || !(per_half_turn >= 2) || per_half_turn != std::round(per_half_turn) || per_half_turn > 4096)
      throw_invalid(name, "orientation_step", step_deg_, "180 / orientation_step an integer in [2, 4096] (degrees)");
    const double levels = std::log2(max_ratio_);
    if (!(max_ratio_ >= 2) || levels != std::round(levels) || levels > 30)
      throw_invalid(name, "max_ratio", max_ratio_, "a power of two in [2, 2^30]");
    max_level_ = static_cast<int>(levels);
    orientations1_ = static_cast<std::int64_t>(per_half_turn);
    area_scale_weights_ = scale_weights_ == "area";
    linear_ratio_weights_ = ratio_weights_ == "linear";
    // Per ratio level (0 to max_level_ + 1): 2^k and the orientation step, tabulated with the same
    // expressions terms() used per term (ldexp is exact, so the table holds the same bits).
    for (int level = 0; level <= max_level_ + 1; ++level) {
      pow2_[static_cast<std::size_t>(level)] = std::ldexp(1.0, level);
      step_[static_cast<std::size_t>(level)] =
          level >= 1 ? std::ldexp(step_deg_ * std::numbers::pi / 180.0, 1 - level) : 0.0;
    }
    params_ = {{"level_ratio", level_ratio},      {"base_area", base_area},        {"scale_weights", scale_weights_},
               {"ratio_weights", ratio_weights_}, {"orientation_step", step_deg_}, {"max_ratio", max_ratio_}};
    name_ = name;
  }

  std::string name() const override { return name_; }
  LawParams params() const override { return params_; }
  bool independent_terms() const override { return true; }
  std::size_t max_terms() const override { return 8; }

  bool terms(const Shape& shape, double density, std::vector<Term>& out) const override {
    bool clamped = false;
    double minor = shape.minor;
    if (shape.ratio > max_ratio_) {  // widen the minor axis: the grids stop at max_ratio
      minor = shape.major / max_ratio_;
      clamped = true;
    }
    const double r = std::min(shape.major / minor, max_ratio_);
    // Scale coordinate from the equivalent rectangle's minor side m = sqrt(π) b.
    const LevelBracket br = ladder_.bracket(std::numbers::pi * minor * minor);
    const double z = area_scale_weights_ ? br.w_area : br.w_lod;
    // Ratio cell [2^k, 2^(k+1)).
    int k = std::max(0, static_cast<int>(std::floor(std::log2(r))));
    k = std::min(k, max_level_);  // r <= max_ratio_ = 2^max_level_: only rounding can land above
    while (k > 0 && pow2(k) > r) --k;
    while (k < max_level_ && pow2(k + 1) <= r) ++k;
    double y;
    if (k >= max_level_) {
      k = max_level_ - 1;
      y = 1.0;
    } else {
      y = linear_ratio_weights_ ? r / pow2(k) - 1.0 : std::log2(r) - k;
    }
    y = std::clamp(y, 0.0, 1.0);
    // Orientation bin of the cell's lower face (level 1 for the isotropic cell).
    const int face = std::max(k, 1);
    const double step = step_[static_cast<std::size_t>(face)];
    const double a = shape.angle / step;
    std::int64_t j = static_cast<std::int64_t>(std::floor(a));
    double x = std::clamp(a - static_cast<double>(j), 0.0, 1.0);
    j = std::min<std::int64_t>(j, orientations(face) - 1);

    // Plane vertices and weights (or the tetrahedron's), then the two scale levels.
    PlaneVertex pv[5];
    int count = 0;
    if (k == 0) {  // triangle: the isotropic grid below, two orientations of ratio 2 above
      pv[count++] = {0, 0, 0.0, 0.0, 0};
      pv[count++] = {1, j, 0.0, 1.0, 10};
      pv[count++] = {1, j + 1, 1.0, 1.0, 12};
    } else {  // pentagon: B, D below; A, C (midpoint), E above
      pv[count++] = {k, j, 0.0, 0.0, 0};
      pv[count++] = {k, j + 1, 1.0, 0.0, 2};
      pv[count++] = {k + 1, 2 * j, 0.0, 1.0, 10};
      pv[count++] = {k + 1, 2 * j + 1, 0.5, 1.0, 11};
      pv[count++] = {k + 1, 2 * j + 2, 1.0, 1.0, 12};
    }
    const double px = k == 0 ? x * y : x;  // the isotropic cell's lower face is one point
    if (!tetrahedral_) {
      double w[5];
      int used[5];
      int m = 0;
      if (k == 0) {
        w[m] = 1 - y, used[m++] = 0;
        w[m] = y * (1 - x), used[m++] = 1;
        w[m] = y * x, used[m++] = 2;
      } else {
        w[m] = (1 - y) * (1 - x), used[m++] = 0;
        w[m] = (1 - y) * x, used[m++] = 1;
        const double x2 = 2 * x;
        if (x2 < 1) {
          w[m] = y * (1 - x2), used[m++] = 2;
          w[m] = y * x2, used[m++] = 3;
        } else {
          w[m] = y * (2 - x2), used[m++] = 3;
          w[m] = y * (x2 - 1), used[m++] = 4;
        }
      }
      const LevelSides sides(br);
      for (int s = 0; s < 2; ++s)
        for (int q = 0; q < m; ++q) push(out, br, sides, s, pv[used[q]], w[q] * (s == 0 ? 1 - z : z), density);
      return clamped;
    }
    // Tetrahedral: the triangle of the plane holding (px, y), its prism over z in [0, 1] cut into 3
    // tetrahedra by the vertices' keys, and the tetrahedron holding the point.
    int tri[3];
    if (k == 0) {
      tri[0] = 0, tri[1] = 1, tri[2] = 2;
    } else if (x <= 0.5 * y) {
      tri[0] = 0, tri[1] = 2, tri[2] = 3;  // B, A, C
    } else if (x >= 1 - 0.5 * y) {
      tri[0] = 1, tri[1] = 3, tri[2] = 4;  // D, C, E
    } else {
      tri[0] = 0, tri[1] = 3, tri[2] = 1;  // B, C, D
    }
    std::sort(tri, tri + 3, [&](int l, int r2) { return pv[l].key < pv[r2].key; });
    // Prism vertices (triangle vertex, level 0 bottom / 1 top); a < b < c by key:
    // {a, b, c, c'}, {a, b, b', c'}, {a, a', b', c'}.
    static constexpr int kTets[3][4][2] = {
        {{0, 0}, {1, 0}, {2, 0}, {2, 1}}, {{0, 0}, {1, 0}, {1, 1}, {2, 1}}, {{0, 0}, {0, 1}, {1, 1}, {2, 1}}};
    const std::array<double, 3> q = {px, y, z};
    int best = 0;
    std::array<double, 4> best_w{};
    double best_min = -1e300;
    for (int t = 0; t < 3; ++t) {
      std::array<std::array<double, 3>, 4> pts;
      for (int v = 0; v < 4; ++v) {
        const PlaneVertex& p = pv[tri[kTets[t][v][0]]];
        pts[static_cast<std::size_t>(v)] = {p.x, p.y, static_cast<double>(kTets[t][v][1])};
      }
      const auto w = weights::barycentric(q, pts);
      const double lo = *std::min_element(w.begin(), w.end());
      if (lo > best_min) best_min = lo, best = t, best_w = w;
    }
    // Rounding can leave -1e-16: clamp and renormalize so the weights stay a partition of unity.
    double sum = 0;
    for (double& w : best_w) sum += (w = std::max(0.0, w));
    const LevelSides sides(br);
    for (int v = 0; v < 4; ++v)
      push(out, br, sides, kTets[best][v][1], pv[tri[kTets[best][v][0]]], best_w[static_cast<std::size_t>(v)] / sum,
           density);
    return clamped;
  }

 private:
  double pow2(int level) const { return pow2_[static_cast<std::size_t>(level)]; }
  std::int64_t orientations(int level) const { return orientations1_ << (level - 1); }
  // The isotropic cell sides of a bracket's two scale levels (one square root each per footprint).
  struct LevelSides {
    double lo, hi;
    explicit LevelSides(const LevelBracket& br) : lo(std::sqrt(br.area_lo)), hi(std::sqrt(br.area_hi)) {}
  };

  void push(std::vector<Term>& out, const LevelBracket& br, const LevelSides& sides, int upper, const PlaneVertex& v,
            double weight, double density) const {
    Term t;
    const int scale = br.lo + upper;
    const std::int64_t count = v.ratio == 0 ? 1 : orientations(v.ratio);
    // The orientation modulo count; the cells' vertices lie in [0, 2 count], so the division is rare.
    std::int64_t orientation = v.orientation;
    if (orientation >= count && orientation < 2 * count)
      orientation -= count;
    else if (orientation < 0 || orientation >= count)
      orientation = ((orientation % count) + count) % count;
    t.grid = {scale, v.ratio, v.ratio == 0 ? 0 : orientation};
    t.angle = v.ratio == 0 ? 0.0 : static_cast<double>(t.grid.orientation) * step_[static_cast<std::size_t>(v.ratio)];
    const double area = upper ? br.area_hi : br.area_lo;
    // Multiplying by 2^ratio is exact, as ldexp: the same bits.
    t.cell_minor = upper ? sides.hi : sides.lo;
    t.cell_major = t.cell_minor * pow2(v.ratio);
    t.cell_area = area * pow2(v.ratio);
    t.weight = weight;
    t.trials = weight * density * t.cell_area;
    out.push_back(t);
  }

  bool tetrahedral_;
  LevelLadder ladder_;
  std::string scale_weights_, ratio_weights_, name_;
  double step_deg_ = 22.5, max_ratio_ = 1048576.0;
  int max_level_ = 20;
  std::int64_t orientations1_ = 8;
  bool area_scale_weights_ = true, linear_ratio_weights_ = true;
  std::array<double, 32> pow2_{}, step_{};  // per ratio level 0 .. max_level_ + 1 (max_level_ <= 30)
  LawParams params_;
};

const bool registered_trilinear = register_grid_scheme(
    {"db23_trilinear",
     "DB23 §5.2: count distributed over the 8 grids of the (scale, ratio, orientation) cell, trilinear weights",
     [](const LawParams& params) { return std::make_unique<Db23Grids>(false, params); },
     {.native_law = "gated"}});  // DB23 count with their gated Gaussian (eq. 16-18)
const bool registered_tetrahedral = register_grid_scheme(
    {"db23_tetrahedral",
     "DB23 §6.1: the (scale, ratio, orientation) cell cut into 9 tetrahedra; 4 grids, barycentric weights",
     [](const LawParams& params) { return std::make_unique<Db23Grids>(true, params); },
     {.native_law = "gated"}});  // DB23 count with their gated Gaussian (eq. 16-18)

}  // namespace
}  // namespace glintlab::aniso
