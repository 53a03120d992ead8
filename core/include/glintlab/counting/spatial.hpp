// Spatialized Bernoulli trials (DB23 §4.1, docs/math/ground_truth.md): the ground truth a counting law must match.
//
// Facets sit on the unit torus; facet i reflects toward the camera iff its uniform theta_i < p, and
// K counts the reflecting facets inside a footprint F. Three layouts:
//   uniform     N i.i.d. uniform positions (N an integer):   K ~ Binomial(N, |F| p)
//   poisson     a Poisson process of intensity N:             K ~ Poisson(N |F| p)
//   stratified  one jittered facet per cell of an M x M grid (N = M^2): cell c adds a
//               Bernoulli(p f_c), f_c = |c ∩ F| / |c| (Poisson-binomial; DB23's layout)
//
// Realizations never materialize facets that cannot matter: the cells of a grid (the strata, or
// buckets of side 1/floor(sqrt N) for the other layouts) are scanned row by row; runs of cells that
// every footprint either fully contains or misses form one group whose count is one draw (binomial
// or Poisson), and only cells crossed by a footprint's edge have their facets placed and tested.
// The cost of a realization is therefore proportional to the footprints' perimeter in cells.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "glintlab/stats/distribution.hpp"

namespace glintlab::spatial {

enum class Layout { kUniform, kPoisson, kStratified };
Layout parse_layout(const std::string& name);  // throws std::invalid_argument naming "layout"
std::string layout_name(Layout layout);

// A convex footprint centred at the origin, lengths in units of the domain's side: a rectangle
// (width x height) or an ellipse (semi-axes a, b), rotated counter-clockwise by `angle` radians.
class Footprint {
 public:
  enum class Kind { kRect, kEllipse };
  static Footprint rect(double width, double height, double angle = 0.0);
  static Footprint ellipse(double a, double b, double angle = 0.0);
  // The pixel footprint of a unit pixel with texture-space derivatives (du/dx, dv/dx) and
  // (du/dy, dv/dy): the ellipse J {|x| <= 1/sqrt(pi)}, J = [[du/dx, du/dy], [dv/dx, dv/dy]], whose
  // area |det J| is the pixel's (the image of the unit square). Axes from the SVD of J.
  static Footprint from_uv_derivatives(double dudx, double dvdx, double dudy, double dvdy);

  Kind kind() const { return kind_; }
  double a() const { return a_; }  // rectangle: width; ellipse: first semi-axis
  double b() const { return b_; }  // rectangle: height; ellipse: second semi-axis
  double angle() const { return angle_; }
  double area() const;
  double half_width() const { return half_w_; }   // half extent of the bounding box along x
  double half_height() const { return half_h_; }  // along y
  bool contains(double x, double y) const;
  // The chord at height y: [lo, hi]; false when the line misses the footprint.
  bool chord(double y, double& lo, double& hi) const;
  // Exact area of the intersection with the box [x0, x1] x [y0, y1].
  double overlap(double x0, double y0, double x1, double y1) const;
  // Heights of the leftmost and rightmost points (where the chord's ends are extreme).
  double y_leftmost() const { return y_left_; }
  double y_rightmost() const { return y_right_; }
  std::string describe() const;

 private:
  Footprint(Kind kind, double a, double b, double angle);
  Kind kind_;
  double a_, b_, angle_, c_, s_, half_w_, half_h_, y_left_, y_right_;
};

// A footprint placed on the torus: its centre (x, y) in [0, 1)^2.
struct Placed {
  Footprint footprint;
  double x, y;
};

class GroundTruth {
 public:
  // Validates everything (std::invalid_argument naming the parameter and value): density N >= 0
  // finite (an integer for uniform, a perfect square M^2 for stratified), p in [0, 1], a footprint
  // whose bounding box fits in the unit domain, a finite centre (wrapped onto [0, 1)) if given.
  GroundTruth(Layout layout, double density, Footprint footprint, double p,
              std::optional<std::pair<double, double>> center = std::nullopt);

  Layout layout() const { return layout_; }
  double density() const { return density_; }
  double p() const { return p_; }
  const Footprint& footprint() const { return footprint_; }
  const std::optional<std::pair<double, double>>& center() const { return center_; }
  double n() const { return density_ * footprint_.area(); }  // expected facets in the footprint
  std::int64_t grid_side() const { return side_; }           // M: cells per side of the scan grid

  // Exact law of K. For the stratified layout with no centre, the law averaged over a uniformly
  // random centre: the midpoint rule on a quadrature x quadrature grid of centre offsets within
  // one cell (the law is periodic in the centre with the cell's period).
  Distribution pmf(std::size_t max_support = kDefaultMaxSupport, int quadrature = 16) const;

  // `count` realizations (one row each, with a random centre when none was given): K of each.
  // Realization r is a function of (seed, r) alone, whatever the number of threads.
  std::vector<double> sample(std::size_t count, std::uint64_t seed) const;

 private:
  Layout layout_;
  double density_, p_;
  Footprint footprint_;
  std::optional<std::pair<double, double>> center_;
  std::int64_t side_;
};

// Counts of the same realizations in several footprints at once (a zoom or pan path): row r of
// the result (count x footprints.size(), row-major) holds K in each footprint for realization r,
// all placed footprints counted on one facet layout. Footprints are given with their centres; they
// must fit in the unit domain together. Realization r is a function of (seed, r) alone.
std::vector<double> joint_counts(Layout layout, double density, double p, const std::vector<Placed>& footprints,
                                 std::size_t count, std::uint64_t seed);

// The exact law's building blocks for a stratified grid of side M and a placed footprint: the
// number of cells fully inside, and the covered fraction of every cell its edge crosses.
struct Coverage {
  double interior = 0;
  std::vector<double> fractions;
};
Coverage stratified_coverage(const Footprint& footprint, double x, double y, std::int64_t side);

// The Poisson-binomial law of a sum of independent Bernoulli(q_i), by dynamic programming on a
// window of +-(12 sd + 30) around the mean (the rest: < 1e-19 by Bernstein's inequality).
Distribution poisson_binomial(const std::vector<double>& q, std::size_t max_support = kDefaultMaxSupport);

}  // namespace glintlab::spatial
