// Glints under extended lights (docs/math/lighting.md): lights as regions of directions, the exact
// probability that a facet drawn from the target's D(m)(m.n) mirrors the view into a light (adaptive
// cubature), and the facet truth lit by the same lights (explicit facets, each with its own normal).
//
// Conventions: the tangent frame, normal +z; wo is the unit direction towards the viewer; a facet of
// normal m reflects wi = 2 (wo.m) m - wo. A light is a region of directions seen from the shading
// point (a distant light: the same region for every point of a footprint). Directions below the
// horizon (wi_z <= 0) are hidden by the surface itself and never lit.
//
// The reflection probability of a light L (docs/math/lighting.md#lighting-probability):
//     p(wo, L) = integral over {m : reflect(wo, m) in L} of D(m) (m.n) dm
//              = integral over wi in L, wi_z > 0, of D(h) (h.n) / (4 (wo.h)) dwi,   h = (wo + wi) / |wo + wi|.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "glintlab/counting/spatial.hpp"

namespace glintlab::lighting {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};

// A shading point's tangent frame in the lights' coordinates (world space): unit tangent t, bitangent b,
// normal n (orthonormal). A curved surface has one per pixel; a distant light is one region of directions
// in world space, so in each pixel's own frame (normal +z) it is that region rotated by the frame.
struct Frame {
  Vec3 t{1, 0, 0}, b{0, 1, 0}, n{0, 0, 1};
  Vec3 to_world(Vec3 w) const {
    return {w.x * t.x + w.y * b.x + w.z * n.x, w.x * t.y + w.y * b.y + w.z * n.y, w.x * t.z + w.y * b.z + w.z * n.z};
  }
  Vec3 to_local(Vec3 w) const {
    return {w.x * t.x + w.y * t.y + w.z * t.z, w.x * b.x + w.y * b.y + w.z * b.z, w.x * n.x + w.y * n.y + w.z * n.z};
  }
};
// Frames from 9 numbers each (t, b, n), checked orthonormal to 1e-6 (std::invalid_argument naming
// `name`[i]); `count` frames expected, or none (an empty vector: every shading point in the lights' frame).
std::vector<Frame> frames_from(std::string_view where, std::string_view name, const std::vector<double>& values,
                               std::size_t count);

enum class Target { kBeckmann, kGgx };
Target parse_target(const std::string& name);  // throws std::invalid_argument naming "target"

// D(m) of an isotropic Beckmann or GGX NDF at (m.n) = c (0 for c <= 0): docs/math/ndf.md#ndf-beckmann.
double ndf_value(Target target, double alpha, double c);

// A convex region of directions: the directions w with w.g >= t for each half-space (g, t), and, for a
// disk, q(w) = w^T Q w <= 0 on the side front.w > 0. A cap is one half-space; a parallelogram its four
// edge planes through the origin and its own plane's front; a disk the cone over its circle.
class Light {
 public:
  enum class Kind { kCap, kRect, kDisk };
  // The directions within `half_angle` (radians, in (0, pi/2]) of `direction` (normalised here).
  static Light cap(Vec3 direction, double half_angle);
  // The parallelogram center +- edge_u / 2 +- edge_v / 2 (positions relative to the shading point).
  static Light rect(Vec3 center, Vec3 edge_u, Vec3 edge_v);
  // The disk of `radius` around `center` in the plane of normal `normal` (relative positions).
  static Light disk(Vec3 center, Vec3 normal, double radius);

  Kind kind() const { return kind_; }
  Vec3 center() const { return center_; }  // unit direction towards the light's centre
  bool contains(Vec3 w) const;             // w unit; the horizon is not part of the light's test
  // The angle rho in (0, pi] along the great circle cos(rho) pole + sin(rho) dir (pole inside the light,
  // dir a unit tangent at the pole) where it leaves the light (and the upper hemisphere when `horizon`).
  double exit(Vec3 pole, Vec3 dir, bool horizon) const;
  // Solid angle (steradians) of the whole light: closed forms for the cap and the parallelogram
  // (Van Oosterom & Strackee's triangle formula twice), cubature for the disk.
  double solid_angle() const;
  // The corners of a parallelogram's outline (relative positions); none for round lights.
  std::vector<Vec3> corners() const {
    return kind_ == Kind::kRect ? std::vector<Vec3>(corners_, corners_ + 4) : std::vector<Vec3>{};
  }
  std::string describe() const;
  // The same light seen in the tangent frame `frame` (every direction mapped by frame.to_local).
  Light in_frame(const Frame& frame) const;

 private:
  struct HalfSpace {
    Vec3 g;
    double t;
  };
  Kind kind_ = Kind::kCap;
  Vec3 center_;
  std::vector<HalfSpace> half_spaces_;
  bool has_cone_ = false;
  double q_[3][3] = {};  // the disk's cone
  Vec3 front_;
  double half_angle_ = 0;  // cap
  Vec3 corners_[4] = {};   // rect, relative positions
};

// A value with its error estimate and the integrand evaluations it cost.
struct Integral {
  double value = 0, error = 0;
  std::int64_t evaluations = 0;
  bool converged = true;
};

// The exact p(wo, L) above by nested adaptive Gauss-Kronrod (7-15) cubature in polar coordinates
// about a pole inside the light (docs/math/lighting.md#lighting-cubature), to the relative error
// `rel_tol` (estimated; `converged` false when max_evaluations ran out first).
Integral reflection_probability(Target target, double alpha, Vec3 wo, const Light& light, double rel_tol = 1e-6,
                                std::int64_t max_evaluations = 4000000);

// The same integral with D held at its value at the half vector of the light's centre: the integral
// of 1 / (4 (wo.h)) over the light above the horizon, the solid angle of the light's half-vector region.
Integral half_vector_solid_angle(Vec3 wo, const Light& light, double rel_tol = 1e-8);

// The solid angle of the light above the horizon (cubature).
Integral visible_solid_angle(const Light& light, double rel_tol = 1e-10);

// Many views at once (one per pixel), threads over pixels, each pixel's value a function of its view
// alone. wo: 3 * count values. With `frames` (one per view, or none) each view's light is `light` seen in
// that view's frame (Light::in_frame): a curved surface's pixels under one distant light. Returns (values, errors).
std::pair<std::vector<double>, std::vector<double>> reflection_probabilities(Target target, double alpha,
                                                                             const std::vector<double>& wo,
                                                                             const Light& light, double rel_tol,
                                                                             const std::vector<Frame>& frames = {});

// An environment map's regions: an equirectangular grid of `rows` x `cols` labels (row 0 at the zenith,
// theta = (i + 1/2) pi / rows; phi = (j + 1/2) 2 pi / cols, the x axis at phi = 0), label -1 for
// none, and the map's radiance per cell.
struct RegionMap {
  int rows = 0, cols = 0, regions = 0;
  std::vector<int> labels;
  std::vector<double> radiance;
  int cell(Vec3 w) const;  // the cell index of a unit direction
};
void check_region_map(const RegionMap& map);  // std::invalid_argument naming the bad field

// p_r(wo) for every region r of the map: the integral of D(h)(h.n) / (4 (wo.h)) over the cells labelled
// r above the horizon, by adaptive cubature row by row (docs/math/lighting.md#lighting-env-exact).
// With `frame` (none: the map's own frame) wo is in that tangent frame, the map's directions are seen in it
// and cut at its horizon: a curved surface's pixel under a world-space map.
std::vector<Integral> region_probabilities(Target target, double alpha, Vec3 wo, const RegionMap& map,
                                           double rel_tol = 1e-6, const Frame* frame = nullptr);
// Many views at once (3 * count values of wo; `frames` one per view or none), threads over views: (values,
// errors), count x regions row-major.
std::pair<std::vector<double>, std::vector<double>> region_probabilities_many(Target target, double alpha,
                                                                              const std::vector<double>& wo,
                                                                              const RegionMap& map, double rel_tol,
                                                                              const std::vector<Frame>& frames = {});

// Which light or region a facet reflects the view into: the one test of "its mirror direction hits the
// light" that every truth under a light shares (the stratified facets below, KPT25's points, WWH18's
// flakes; docs/math/lighting.md#lighting-facets, #lighting-own-truths). Channels: the lights (the first
// that contains the direction) or the map's regions.
class LightHit {
 public:
  LightHit(std::vector<Light> lights, std::vector<double> radiance);  // one radiance per light
  explicit LightHit(RegionMap map);                                   // checked (check_region_map)
  int channels() const { return channels_; }
  // The channel (-1: none) a facet of unit normal m lit through the unit view wo reflects, and in `radiance`
  // the radiance it receives: none when wo.m <= 0 (turned away from the viewer) or the mirror direction
  // 2 (wo.m) m - wo is below the horizon. mirror = false tests m itself in place of the mirror direction:
  // a deliberately wrong variant the tests use to show that their checks can fail. wo and m are in the
  // shading point's tangent frame; `frame` (none: the lights' own frame) maps the mirror direction to the
  // lights' (world) coordinates before the light or the map is looked up, after the horizon test.
  int hit(Vec3 wo, Vec3 m, double& radiance, bool mirror = true, const Frame* frame = nullptr) const;
  bool is_map() const { return is_map_; }
  const std::vector<Light>& lights() const { return lights_; }  // none for a map
  double light_radiance(int k) const { return radiance_[k]; }

 private:
  std::vector<Light> lights_;
  std::vector<double> radiance_;
  RegionMap map_;
  bool is_map_ = false;
  int channels_ = 0;
};

// The facet truth under lights (docs/math/lighting.md#lighting-facets): the stratified layout of side
// `side` (one facet per cell, jittered; density side^2), each facet with its normal drawn from
// D(m)(m.n); in each placed footprint, every facet inside, whose mirror direction of its pixel's view
// wo hits a light (the first that contains it) or a region of the map, is counted for that light or
// region, and adds the radiance there. `frames` (one per footprint, or none) are the footprints' tangent
// frames in the lights' coordinates (LightHit::hit): a curved surface under distant lights.
struct FacetTruth {
  std::vector<double> counts;    // footprints x channels, row-major (channels: lights or regions)
  std::vector<double> radiance;  // per footprint: the sum of the reflecting facets' radiance
  std::vector<double> facets;    // per footprint: facets inside it
};
FacetTruth facet_truth_lights(Target target, double alpha, std::int64_t side,
                              const std::vector<spatial::Placed>& footprints, const std::vector<double>& wo,
                              const std::vector<Light>& lights, const std::vector<double>& radiance, std::uint64_t seed,
                              const std::vector<Frame>& frames = {});
FacetTruth facet_truth_map(Target target, double alpha, std::int64_t side,
                           const std::vector<spatial::Placed>& footprints, const std::vector<double>& wo,
                           const RegionMap& map, std::uint64_t seed, const std::vector<Frame>& frames = {});

}  // namespace glintlab::lighting
