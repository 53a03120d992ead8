// WWH18's filterable discrete-flake model (Wang, Wang and Holzschuch 2018) beside its truth, the discrete
// stochastic microfacets of JHY14 (WWH18 eq. 1-4). The mathematics, every reading of the printed text
// and the normalisations: docs/math/wwh18.md.
//
// - The truth: a Poisson process of flakes, density N per unit texture area, generated per base cell of
//   texture space; each flake's normal drawn exactly from D(m)(m.n). The count of a pixel is the number of
//   flakes in its footprint parallelogram whose normal lies in the cone of half-angle gamma around h;
//   its exact law is Poisson(N |A| p_gamma(h)), p_gamma(h) the cone's mass under D(m)(m.n).
// - The model: the directional probability function P (eq. 7) from a table (Sec. 4.2-4.3), the spatial
//   traversal of Algorithm 1 (eq. 8-9) over a quadtree of the same base cells (so both see the same
//   flakes), and the switch to the filtered count N |A| P above a threshold T (eq. 10).
//
// Determinism: a cell's flake count, a flake's position and normal and every lambda are pure functions
// of (seed, cell or node, index); pixels are independent, so results do not depend on the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "glintlab/glinty/glinty_ndf.hpp"  // GlintTarget

namespace glintlab {

namespace lighting {
class LightHit;
struct GlintLightOptions;
struct LightNodes;
struct Vec3;
}  // namespace lighting

// Which lambda a flake is tested with (Algorithm 1's psi <- lambda(k); eq. 8's lambda(x)).
enum class WwhLambdaSeeding {
  node,   // as printed: one lambda per node (seeded by the node id), shared by every flake of the node
  flake,  // one lambda per flake, keyed by its base cell and its index there (independent of the node)
  pixel,  // eq. 8's lambda(x) read with x the query's position: one lambda per pixel, keyed by its uv
};

// Which cone a flake must reflect into (eq. 3-4's Omega_h; Sec. 4.1's "a cone centered around omega_o").
enum class WwhCone {
  half_vector,  // the normal m within gamma of the half vector h (the cone Omega_h of eq. 4)
  outgoing,     // the reflection of wi about m within gamma of wo (Sec. 4.1's cone around omega_o)
};

// The threshold test of eq. 8-9.
enum class WwhThresholdTest {
  printed,  // H(lambda - P): a flake counts when lambda > P, with probability 1 - P (eq. 8 as printed)
  flipped,  // H(P - lambda): a flake counts when lambda < P, with probability P
};

enum class WwhRng { tea, philox };  // the generator of lambda: TEA as the paper, or Philox4x32-10

enum class WwhDpf {
  table,  // P from the precomputed table (Sec. 4.2-4.3): accumulated, tabulated, blurred, interpolated
  exact,  // P = p_gamma(h) by quadrature: isolates the spatial traversal's own error
};

struct Wwh18Params {
  double density = 1e6;  // N: flakes per unit texture area
  GlintTarget target = GlintTarget::beckmann;
  double alpha = 0.5;
  double gamma_deg = 6.0;        // cone half-angle (degrees)
  double flakes_per_cell = 4.0;  // expected flakes per base cell (cell side sqrt(flakes_per_cell / N))
  WwhLambdaSeeding lambda_seeding = WwhLambdaSeeding::node;
  WwhCone cone = WwhCone::half_vector;
  WwhThresholdTest threshold_test = WwhThresholdTest::printed;
  WwhRng rng = WwhRng::tea;
  int tea_rounds = 4;
  // Error criterion of Algorithm 1: a partly covered node is counted with its fractional overlap when
  // it is a base cell, or when its area is at most error_eps |A| (0: base cells only).
  double error_eps = 0.0;
  double T = 16.0;  // filtered model (eq. 10) when N |A| P > T; infinity: never
  WwhDpf dpf = WwhDpf::table;
  double table_res_deg = 1.0;  // table resolution (degrees), a divisor of 90
  double lod_deg = 0.0;        // blur of the table (Sec. 4.3): 0 none, else one of 1,2,5,10,20,30,45,60,90
  bool float32 = true;         // table values rounded to float32 (6.00 MB at 1 degree: the paper's 5.7, in MiB)
};

// Cells (base cells of the flakes, nodes of the traversal) are keyed by their full 64-bit indices in the
// random numbers; a footprint must lie within this many base cells of the origin, where the indices'
// bits above 32 still fit their fields (docs/math/wwh18.md#wwh18-truth). Beyond it uv is refused by name.
inline constexpr double kWwhMaxCellIndex = 274877906944.0;  // 2^38

// The hierarchy levels of Sec. 4.3 (degrees).
inline constexpr double kWwhLodLevels[9] = {1, 2, 5, 10, 20, 30, 45, 60, 90};

// What counts() did for one pixel.
enum WwhMode : int { kWwhZero = 0, kWwhTraversal = 1, kWwhFiltered = 2 };

class Wwh18Ndf {
 public:
  explicit Wwh18Ndf(const Wwh18Params& params);  // throws std::invalid_argument naming the parameter
  const Wwh18Params& params() const { return p_; }
  double cell_side() const { return s0_; }
  // sigma(gamma) of eq. 3: the cone's solid angle 4 pi sin^2(gamma / 2) (no cancellation as gamma -> 0).
  double cone_solid_angle() const { return cone_solid_angle_; }

  // p_gamma(h): the mass of D(m)(m.n) in the cone of half-angle gamma around h (nested adaptive
  // Gauss-Kronrod over the cone; absolute error about 1e-10). h need not be normalised.
  double cone_mass(const double h[3]) const;
  // The outgoing-cone reading: the mass of D(m)(m.n) over the normals m that reflect wi into the cone of
  // half-angle gamma around wo, by quadrature over that cone of D(h')(h'.n) / (4 wi.h'), h' the half
  // vector of (wi, w) (the Jacobian of w -> h'). Both need not be normalised.
  double outgoing_cone_mass(const double wi[3], const double wo[3]) const;
  // The accumulated value of Sec. 4.2 at h itself: the sum of the masses of the table's hemisphere
  // cells (side table_res_deg) whose centre lies within gamma of h.
  double accumulated(const double h[3]) const;
  // P(wi, wo) looked up in the (blurred) table by trilinear interpolation in (theta_i, theta_o, dphi).
  double dpf(const double wi[3], const double wo[3]) const;
  // The P the model uses for a pixel: dpf(wi, reflect(wi, h)) (wi = h when null), or cone_mass(h)
  // (outgoing_cone_mass(wi, reflect(wi, h)) with the outgoing cone).
  double model_p(const double h[3], const double* wi) const;

  // Per pixel i: uv[2i..], J[4i..] = (du/dx, dv/dx, du/dy, dv/dy), h[3i..] (tangent frame, +z normal).
  // The truth's count (integer valued); wi (may be null: wi = h) only matters with the outgoing cone.
  void reference_counts(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                        double* out, const double* wi = nullptr) const;
  // The model's count (real valued: fractional overlaps, or N |A| P when filtered); wi may be null;
  // mode[i] (if not null) receives a WwhMode, p_out[i] (if not null) the P used.
  void counts(const double* uv, const double* jac, const double* h, const double* wi, std::size_t m, std::uint64_t seed,
              double* out, int* mode = nullptr, double* p_out = nullptr) const;
  // The truth's flakes lit by an extended light (docs/math/lighting.md#lighting-own-truths): every flake of the
  // footprint parallelogram, opt.lit_as kNormal: counted for the channel `hit` gives its mirror direction of
  // the view wo[3i..]; kLobe: its cone of half-angle gamma (the model's cone: around the normal in half
  // vectors, or around the mirror direction in directions of light), of density 1 / sigma(gamma) there,
  // integrated over each light or region (lobes.hpp, docs/math/lighting.md#lighting-lobes).
  // counts[i * channels + c], radiance[i] (the sum of their radiance), flakes[i] (the flakes in the footprint).
  void light_counts(const double* uv, const double* jac, const double* wo, std::size_t m, std::uint64_t seed,
                    const lighting::LightHit& hit, const lighting::GlintLightOptions& opt, double* counts,
                    double* radiance, double* flakes) const;

  // lambda of (level, i, j, k) as the model draws it (exposed for the generator's quality tests).
  double lambda(std::uint64_t seed, int level, std::int64_t i, std::int64_t j, std::uint32_t k) const;
  // lambda(x) of one pixel with lambda_seeding = pixel: a pure function of (seed, the bits of u and v).
  double pixel_lambda(std::uint64_t seed, double u, double v) const;
  // Table geometry (tests, documentation).
  int table_size(int axis) const { return dims_[axis]; }
  std::size_t table_bytes() const { return table_.size() * (p_.float32 ? 4 : 8); }

 private:
  struct Footprint;
  std::uint32_t cell_count(std::uint64_t seed, std::int64_t i, std::int64_t j) const;
  double node_pass(const Footprint& fp, std::uint64_t seed, int level, std::int64_t i, std::int64_t j, double p) const;
  double traverse(const Footprint& fp, std::uint64_t seed, double p) const;
  void check_range(const Footprint& fp, std::size_t index) const;
  bool passes(double psi, double p) const;
  // f(m) for the unit normal m of every flake of the truth inside the footprint (one enumeration for
  // reference_counts and light_counts).
  template <class F>
  void for_each_flake(const Footprint& fp, std::size_t index, std::uint64_t seed, F&& f) const;
  bool flake_counts(const double m[3], const double h[3], const double wi[3], const double wo[3]) const;
  // One flake's cone (normal m, view v) integrated over the lights: adds its share of each channel to c and
  // of the radiance to radiance; light_rule: per light, scratch.
  void cone_counts(const lighting::LightHit& hit, const lighting::GlintLightOptions& opt,
                   const lighting::LightNodes& nodes, const double v[3], const double m[3],
                   std::vector<char>& light_rule, double* c, double& radiance) const;
  // The cone's share of light k (centre ctr: the normal for a cone of half vectors, the mirror direction for
  // the outgoing cone) by the rays of its light rule: the cone's edge located on each ray by bisection, the
  // pieces inside integrated by 3-point Gauss-Legendre (cone_counts; docs/math/lighting.md#lighting-lobes).
  double cone_over_light(const lighting::LightHit& hit, const lighting::LightNodes& nodes, int k, int rings,
                         const double v[3], const lighting::Vec3& ctr) const;
  double band_mass(double t0, double t1) const;  // mass of D(m)(m.n) with theta_m in [t0, t1], radians
  void build_cells();
  void build_table();
  void blur_table();

  Wwh18Params p_;
  double s0_ = 0.0, cos_gamma_ = 1.0, cone_solid_angle_ = 0.0;
  double chord2_ = 0.0;  // |m - h|^2 at angle gamma: 4 sin^2(gamma / 2), the cone test without cancellation
  int dims_[3] = {0, 0, 0};
  std::vector<double> table_;
  std::vector<double> band_ct_, band_st_, band_mass_;  // the hemisphere grid's bands (mass per cell)
};

// TEA (Wheeler and Needham 1995) on the block (v0, v1) with the 128-bit key k, `rounds` Feistel cycles.
void tea_encrypt(std::uint32_t& v0, std::uint32_t& v1, const std::uint32_t k[4], int rounds);

// The mass of D(m)(m.n) with polar angle below theta (closed forms: the CDF of theta under D(m)(m.n)).
double wwh18_theta_cdf(GlintTarget target, double alpha, double theta);

}  // namespace glintlab
