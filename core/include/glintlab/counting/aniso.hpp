// Anisotropic pixel footprints and the virtual grids that count glints in them (docs/math/grids.md;
// DB23 §5-6 and the ZK16 baseline of DB23 §7 / Fig. 11).
//
// A pixel's footprint in texture space is the ellipse spanned by its UV derivatives: area P,
// semi-axes a >= b, ratio r = a / b, orientation φ of the major axis in [0, π). A *grid scheme* turns
// the footprint into a short list of terms, each "evaluate the inner counting law with t trials on
// virtual grid g (at an offset), and add s times the result to K":
//
//   db23_trilinear    DB23 §5.2: grids scaled (s), stretched (ratio 2^k) and rotated (φ_j); the count
//                     is distributed (eq. 10) over the 8 grids at the corners of the (s, r, φ) cell
//                     that holds the footprint, with trilinear weights.
//   db23_tetrahedral  DB23 §6.1: the same cell cut into 9 tetrahedra (3 in the isotropic cell r < 2);
//                     4 grids with barycentric weights.
//   zk16_aniso        ZK16: isotropic mip grids and manual anisotropic filtering, min(ceil r, 16)
//                     isotropic probes along the major axis, each blended between two mip levels;
//                     beyond r = max_aniso the footprint is widened.
//
// How the grids sit (glintlab's definitions, from the public shader where the paper is silent):
//   * The ellipse's equivalent rectangle has the same area and ratio: sides m = sqrt(π) b across and
//     r m along the major axis, so P = r m^2.
//   * Scale level l has isotropic cells of area A_l = base_area · level_ratio^l; the scale coordinate
//     comes from the minor side m (the public shader's choice): A_l <= m^2 < A_{l+1}. Its weight is
//     z = (m^2 - A_l) / (A_{l+1} - A_l) ("area", DB23 eq. 10: conserves the expected count) or
//     z = log(m^2 / A_l) / log(level_ratio) ("log", the public shader's frac(lod)).
//   * Ratio level k has cells 2^k times longer along the grid's direction, area 2^k A_l; for
//     2^k <= r < 2^(k+1) the ratio weight is y = r / 2^k - 1 ("linear", the shader) or log2 r - k ("log").
//   * Ratio level k >= 1 has orientations j Δ_k, Δ_k = orientation_step / 2^(k-1) (22.5° at k = 1, as
//     the shader's 90° / max(ratio, 2) / 2), over [0, π); level 0 is isotropic (one grid, φ ignored).
//     Between levels k and k + 1 the (φ, r) cell is a pentagon: 2 orientations below, 3 above (the
//     upper level's spacing is half); between 0 and 1 it is a triangle (the isotropic vertex below).
//
// An AnisoCounter evaluates a scheme with an inner law on cells: term t's grid is keyed by its
// (scale, ratio, orientation) level, the cell containing the pixel position in that grid's rotated and
// stretched coordinates, and an angular texel, so a realization is coherent across pixels. Realizations
// may be interpolated (docs/math/grids.md#grid-realizations): spatially over the 4 corners of a square cell or the 3
// vertices of a simplex (triangle) cell, angularly over 4 texels (DB23 eq. 14), either blended with the interpolation
// weights v_j (mean kept, variance scaled by Σ v_j^2) or by selecting one vertex with probability v_j (the marginal law
// kept exactly).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "glintlab/base/registry.hpp"
#include "glintlab/counting/blend.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/distribution.hpp"

namespace glintlab::aniso {

enum class ShapeStatus : std::uint8_t {
  kOk = 0,
  kDegenerate = 1,  // det J = 0, or a ratio beyond 1e12: no ellipse to count in
  kNonFinite = 2,   // a derivative is NaN or infinite
  kClamped = 3,     // valid, but the scheme changed it (ratio beyond its cap: footprint widened)
};
const char* status_name(ShapeStatus status);

// The footprint ellipse: area P = π a b, semi-axes a >= b, ratio a / b, major-axis angle in [0, π).
struct Shape {
  double area = 0, major = 0, minor = 0, ratio = 1, angle = 0;
  ShapeStatus status = ShapeStatus::kOk;
};

inline constexpr double kMaxRatio = 1e12;

// The ellipse J {|x| <= 1/sqrt(π)} for J = [[du/dx, du/dy], [dv/dx, dv/dy]]: the image of a unit
// pixel (area |det J|), axes from the SVD of J. Never throws: bad input is reported in `status`.
Shape shape_from_jacobian(double dudx, double dvdx, double dudy, double dvdy);
// The ellipse of area P, ratio r >= 1 and angle φ (radians, any real: taken modulo π). Throws
// std::invalid_argument naming the parameter for P <= 0, r < 1 or r > 1e12, non-finite values.
Shape shape_from_params(double area, double ratio, double angle);

// One virtual grid: scale level, ratio level and orientation index at that ratio level.
struct GridId {
  int scale = 0;
  int ratio = 0;
  std::int64_t orientation = 0;
};

// One evaluation of the inner law in a pixel's count (see the file comment).
struct Term {
  GridId grid;
  double angle = 0;       // direction of the grid's long cell side (radians)
  double cell_minor = 1;  // cell side across that direction
  double cell_major = 1;  // cell side along it
  double dx = 0, dy = 0;  // probe offset from the pixel centre (texture units)
  double weight = 0;      // the scheme's interpolation weight (for reports)
  double cell_area = 0;
  double trials = 0;  // n handed to the inner law
  double scale = 1;   // K += scale · count
};

class GridScheme {
 public:
  virtual ~GridScheme() = default;
  virtual std::string name() const = 0;
  virtual LawParams params() const = 0;
  // Appends the terms of a footprint (status kOk) for facet density N; returns true when the scheme
  // had to change the footprint (kClamped). Terms are structural: a term whose weight happens to be 0
  // is still listed, so the count of terms depends on the cell type only, as in a shader.
  virtual bool terms(const Shape& shape, double density, std::vector<Term>& out) const = 0;
  // Every term has scale 1 and a grid of its own (so the terms' counts are independent and K is
  // their sum): then an exact law exists when the inner law has one.
  virtual bool independent_terms() const = 0;
  virtual std::size_t max_terms() const = 0;
};

using GridSchemeFactory = std::function<std::unique_ptr<GridScheme>(const LawParams&)>;
// What a scheme declares with its code (studies derive their pairings from it, not from name lists).
struct GridSchemeTraits {
  // The counting law the scheme's authors evaluate on its grids (zk16_aniso: "zk16"; DB23's grids:
  // "gated"), used when a study pairs each scheme with its own law. Empty: none declared.
  std::string native_law{};
};
struct GridSchemeInfo {
  std::string name;
  std::string summary;
  GridSchemeFactory make;
  GridSchemeTraits traits{};
};
// All grid schemes (a function-local static: schemes register from static initializers).
Registry<GridSchemeInfo>& grid_scheme_registry();
bool register_grid_scheme(GridSchemeInfo info);
std::vector<GridSchemeInfo> registered_grid_schemes();
std::unique_ptr<GridScheme> make_grid_scheme(const std::string& name, const LawParams& params = {});

enum class Spatial { kNone, kSquare, kSimplex };
enum class Angular { kNone, kBilinear };
enum class Realization { kBlend, kSelect };
Spatial spatial_from_name(const std::string& name);          // none, square, simplex
Angular angular_from_name(const std::string& name);          // none, bilinear
Realization realization_from_name(const std::string& name);  // blend, select
std::string spatial_name(Spatial s);
std::string angular_name(Angular a);
std::string realization_name(Realization r);

struct CounterOptions {
  Spatial spatial = Spatial::kNone;
  Angular angular = Angular::kNone;
  Realization realization = Realization::kSelect;
};

// Per-pixel output of AnisoCounter::count_pixels.
struct PixelOutput {
  double* count;              // K (0 where status is kDegenerate / kNonFinite)
  std::int32_t* evaluations;  // inner-law evaluations the pixel costs
  std::uint8_t* status;       // ShapeStatus
};

class AnisoCounter {
 public:
  AnisoCounter(std::shared_ptr<const GridScheme> scheme, InnerLaw inner, CounterOptions options);

  const GridScheme& scheme() const { return *scheme_; }
  const InnerLaw& inner() const { return inner_; }
  const CounterOptions& options() const { return options_; }

  // Inner-law evaluations per term for these options (1, 3, 4, 12 or 16; 1 when selecting).
  int evaluations_per_term() const;
  // K is an integer whenever the inner law's counts are (no blended realizations, scale-1 terms).
  bool integer_output() const;
  bool has_pmf() const;

  // The terms of one footprint (validated; std::invalid_argument naming the parameter).
  std::vector<Term> terms(double density, const Shape& shape, bool* clamped = nullptr) const;

  // A whole image: pixel i at texture position uv[2i..2i+1] with Jacobian jac[4i..4i+3] = (du/dx,
  // dv/dx, du/dy, dv/dy), angular coordinate slope[2i..2i+1] (texel units; nullptr: 0). p has 1 or m
  // values. Every pixel uses the same grids (seed): neighbouring pixels share cells. Both cores; the
  // output does not depend on the thread count.
  void count_pixels(double density, ParamArray p, const double* uv, const double* jac, const double* slope,
                    std::size_t m, std::uint64_t seed, PixelOutput out) const;

  // `count` independent realizations of K for one footprint: realization r has its own grids (from
  // (seed, r)), a uniformly random position within every grid's cells and a random angular coordinate.
  void sample(double density, double p, const Shape& shape, std::size_t count, std::uint64_t seed, double* out) const;

  // Exact law of K (realizations selected, or not interpolated; independent terms; an inner law with an
  // exact law and integer counts); throws not_implemented otherwise.
  Distribution pmf(double density, double p, const Shape& shape, std::size_t max_support = kDefaultMaxSupport) const;

 private:
  // What every pixel shares when all have the same footprint and p (sample()): its terms, and one
  // evaluator per term (null where the term has none), used for the rows of that term. No member
  // initializers: `= {}` in run()'s declaration value-initializes both to null, and Clang refuses a
  // default argument that needs a nested class's member initializers inside the enclosing class.
  struct SharedFootprint {
    const std::vector<Term>* terms;
    const std::vector<std::shared_ptr<const detail::FixedEvaluator>>* fixed;
  };
  // Runs pixels [0, m) in chunks, each through the stages of detail/aniso_stages.hpp (footprint terms,
  // term cells, evaluate, accumulate): source(i, pixel, shape) fills pixel i's position, p, seeds and
  // footprint (detail::aniso_stages::Pixel).
  template <class Source>
  void run(double density, std::size_t m, Source source, double* k, std::int32_t* evaluations, std::uint8_t* status,
           SharedFootprint shared = {}) const;
  std::shared_ptr<const GridScheme> scheme_;
  InnerLaw inner_;
  CounterOptions options_;
};

// Interpolation weights, exposed for tests (points are in the unit cell's coordinates).
namespace weights {
// Barycentric weights of (x, y, z) in the tetrahedron a, b, c, d (each {x, y, z}).
std::array<double, 4> barycentric(const std::array<double, 3>& q, const std::array<std::array<double, 3>, 4>& t);
// The simplex (triangle) lattice vertices around grid point (X, Y): cell offsets and weights.
struct Vertex2 {
  std::int64_t i, j;
  double w;
};
int spatial_vertices(Spatial spatial, double X, double Y, Vertex2* out);  // returns 1, 4 or 3
}  // namespace weights

}  // namespace glintlab::aniso
