// KPT25's glinty NDF (Kemppinen et al. 2025, "Evaluating and Sampling Glinty NDFs in Constant Time"):
// the point process of their §3.3.1-3.3.2, the full sum of eq. 5/11's first term over that process (the
// reference), and the constant-time evaluation of their Algorithm 1 (k angular neighbours B(k), the
// compensation of eq. 9/10, two MIP levels with the mollified roulette of eq. 8). The mathematics, the
// normalisation and every policy where the paper is silent: docs/math/glinty_ndf.md.
//
// Determinism: every point is a pure function of (seed, level, spatial cell, angular cell) through
// Philox4x32-10 (rng.hpp), and every pixel is computed independently, so an image is the same whatever
// the number of threads or the order of the pixels.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace glintlab {

class CounterRng;
namespace lighting {
class LightHit;
struct GlintLightOptions;
}  // namespace lighting
namespace kpt25 {
struct LobeView;  // kpt25_lights.cpp: one pixel's view of the lights for the lobes
}

enum class GlintTarget { beckmann, ggx };

// How the points outside B(k) are accounted for (eq. 9 and 10).
enum class GlintCompensation {
  square,          // eq. 10: the Gaussian integrated over the unit square minus its part in B(k) (the paper)
  disk,            // eq. 9: over the disk U minus its part in B(k), by quadrature (the exact expectation)
  none,            // no compensation: the truncation to B(k) alone
  square_flipped,  // eq. 10 with the sign of its second term flipped: a deliberately wrong NDF the tests
                   // use to show that their checks can fail
};

// How the two MIP levels are combined (§3.3.3).
enum class GlintBlend {
  roulette,  // each point of level l kept with weight R(r, w_l) of eq. 8 (epsilon = 0: the exact roulette)
  linear,    // each point weighted by w_l (the linear blending the paper argues against, Fig. 6)
};

// UV-free glints (KPT25 §3.3.6, docs/math/glinty_ndf.md#glinty-triplanar): how the three planes'
// weights come from the normal n.
enum class TriplanarWeights {
  normalized,  // w_i = |n_i|^s / sum_j |n_j|^s (s = triplanar_sharpness; 1: the paper's |n.axis|, normalised)
  printed,     // w_i = |n_i|^s as printed, not normalised (sum in [1, sqrt 3] at s = 1: biased in the mean)
  missing_xy,  // normalised over three planes but the xy plane never evaluated: a deliberately wrong blend
               // the tests use to show that their checks can fail
};

struct Kpt25Params {
  double density = 1e6;  // K_P: points per unit texture area (cells of [0, 1)^4 per unit uv area)
  GlintTarget target = GlintTarget::beckmann;
  double alpha = 0.5;                   // roughness of the target NDF
  double alpha_star = 0.02;             // micro-roughness of one facet (eq. 4; angular std sqrt(D(h)) alpha_star)
  int k = 4;                            // angular neighbours per level: 1, 4, 9 or 16 (a square block of cells)
  double epsilon = 0.1;                 // eq. 8's mollification, in [0, 0.5]
  double filter = 0.28209479177387814;  // pixel filter std in pixels (default 1/(2 sqrt(pi)): effective area = |det J|)
  GlintCompensation compensation = GlintCompensation::square;
  GlintBlend blend = GlintBlend::roulette;
  // Algorithm 2 (sample / pdf): the probability beta with which a draw samples the smooth target
  // D(h)(h.n) instead of the lobes (a defensive mixture; 0 = the paper, whose sampler leaves the
  // compensation term out). docs/math/glinty_ndf.md#glinty-sampling.
  double sample_smooth = 0.0;
  // Algorithm 2's reservoir weight of a point (line 12's integral, read two ways): true = the mass of
  // the point's own lobe inside the block B (the default: the block's conditional density is then
  // proportional to eq. 11's explicit terms), false = R f alone, as printed (the integral names the
  // Gaussian at x_a - x, the same for every point), lobes with no mass in B left out.
  bool sample_lobe_mass = true;
  // GGX only: T = L o M~ with the Lambert projection of eq. 7 (true, the paper as printed: it makes
  // D(h) |M^T h| dOmega uniform on U, not D(h)(h.n) dOmega) instead of the orthographic one (false, the
  // default: exact for D(h)(h.n) dOmega). docs/math/glinty_ndf.md#glinty-lambert.
  bool ggx_lambert = false;
  // With ggx_lambert, the Jacobian pdf() uses: false = the Lambert map's own, (pi / 8) D(h) |M^T h| (the
  // sampler's density); true = eq. 6 read with its printed exponent 4, (pi / 8) D(h): not the density of
  // the draws (a reading kept so that the tests show the pdf's integral rejecting it).
  bool lambert_printed_jacobian = false;
  // Anisotropic roughness (eq. 6's stretch M = diag(1 / alpha, 1 / alpha_y, 1), Atanasov et al.): alpha is
  // then alpha_x; 0 = isotropic (alpha_y = alpha). docs/math/glinty_ndf.md#glinty-anisotropy.
  double alpha_y = 0.0;
  // Anisotropic glints (Algorithm 1's A_* = diag(glint_ax, glint_ay): x_s = A_* uv, angular std
  // alpha_star sqrt(D) / a per axis). The grid resolution: sqrt(K_P / det A_*) (policy: K_P points per
  // unit uv area, the mean stays D(h)) or, printed, sqrt(K_P) det(A_*^-1) (line 1).
  // docs/math/glinty_ndf.md#glinty-astar.
  double glint_ax = 1.0, glint_ay = 1.0;
  bool glint_printed_density = false;
  // UV-free (triplanar) glints: the weights of the three planes, their sharpness s (> 0), and whether
  // the planes share one point process (true: the random numbers of a cell do not depend on the plane,
  // so planes that see the same coordinates see the same points) or have one each (false, the default).
  TriplanarWeights triplanar_weights = TriplanarWeights::normalized;
  double triplanar_sharpness = 1.0;
  bool triplanar_shared_seeds = false;
};

// One plane of a triplanar pixel: its coordinates (two world axes), its footprint J (the screen
// derivatives of those coordinates), its blend weight and the tag that selects its point process.
struct TriplanarPlane {
  double u = 0.0, v = 0.0;
  double J[4] = {0.0, 0.0, 0.0, 0.0};
  double weight = 0.0;
  std::uint32_t tag = 0;
  int axis = 0;  // the plane's normal: 0 = x (the yz plane), 1 = y (xz), 2 = z (xy)
};

// Maximum MIP level: the angular grid has 2^l x 2^l cells, l <= 15 (the random-number layout's limit).
inline constexpr int kGlintMaxLevel = 15;

// Angular cells farther than this many lobe stds from T(h) add exp(-x^2 / 2) = 0 in double arithmetic.
inline constexpr double kGlintUnderflowRadius = 39.0;

// The geometry of one pixel that both evaluations share: target value, angular position, lobe width,
// levels and weights, spatial filter.
struct GlintPixel {
  double D = 0.0;             // D(h) of the smooth target (0 below the horizon)
  double xa = 0.5, ya = 0.5;  // T(h) in the unit square (the disk U has centre (1/2, 1/2), radius 1/2)
  double sigma = 0.0;         // angular std alpha_star sqrt(D(h)) (Algorithm 1, line 12); along x with A_*
  double sigma_y = 0.0;       // along y (= sigma without anisotropic glints)
  double lambda = 0.0;        // fractional MIP level
  // The reference's angular reach in lobe stds: cells farther than reach x sigma from T(h) are skipped
  // (39: every term skipped underflows to 0, the exact sum; a smaller reach from a tolerance, reference()).
  double reach = kGlintUnderflowRadius;
  int levels[2] = {0, 0};
  double weights[2] = {1.0, 0.0};
  int n_levels = 1;
  // Spatial filter: inverse covariance (a, b; b, c), normalisation, box half widths (3 sigma).
  double inv_a = 0.0, inv_b = 0.0, inv_c = 0.0, norm = 0.0, half_u = 0.0, half_v = 0.0;
  std::size_t index = 0;      // the pixel's index (error messages)
  const double* J = nullptr;  // its four derivatives (error messages)
};

// The reference refuses a pixel that would sum more cells than this (a footprint far too large for the
// density): its cost grows with the points in the footprint, and an unbounded call would seem to hang.
inline constexpr double kGlintMaxReferenceCells = 2e8;

class Kpt25Ndf {
 public:
  // Throws std::invalid_argument naming the parameter and its value.
  explicit Kpt25Ndf(const Kpt25Params& params);
  const Kpt25Params& params() const { return p_; }

  // Per pixel i: uv[2i..], J[4i..] = (du/dx, dv/dx, du/dy, dv/dy) as in count_image, h[3i..] a half
  // vector in the tangent frame (normal = +z; normalised here; h_z <= 0 gives 0). m pixels, out[m].
  void evaluate(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                double* out) const;
  // The full sum of eq. 11's first term over every point of the same realization (both levels, same
  // roulette), no truncation to B(k) and no compensation. out_points[i] (if not null): points summed.
  // tol = 0: the exact sum. tol > 0: the lobes farther than r stds from T(h) are left out, with r chosen
  // per pixel so that the value moves by at most tol x D(h) x W / K_P, W the pixel's filter weight summed
  // over every point (W / K_P is pi / 4 in expectation); docs/math/glinty_ndf.md#glinty-reference-reach.
  void reference(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed, double* out,
                 double* out_points = nullptr, double tol = 0.0) const;
  // Exact expectations over realizations (random seed, random position) for these footprints and half
  // vectors: e_ref = E[reference], e_alg = E[evaluate]. Either pointer may be null.
  void expected(const double* jac, const double* h, std::size_t m, double* e_ref, double* e_alg) const;

  // Algorithm 2 (docs/math/glinty_ndf.md#glinty-sampling): one half vector per row i drawn from the pdf
  // of pixel (uv[2i..], J[4i..]) for realization `seed`; the draw's random numbers are a pure function
  // of (draw_seed, i). h_out[3i..] the half vector (NaN when the drawn lobe point falls outside the
  // disk U: a lost sample, pdf 0), pdf_out[i] its density per steradian of h (exactly pdf() below), and
  // if wo is not null (3 numbers per row, normalised here), wi_out[3i..] = reflect(wo, h) = 2 (wo.h) h - wo,
  // NaN where wo.h <= 0 (a facet facing away from wo reflects nothing: policy, so that the density of wi
  // is pdf(h) / (4 wo.h) at the one h = normalise(wi + wo) with wo.h > 0).
  void sample(const double* uv, const double* jac, const double* wo, std::size_t m, std::uint64_t seed,
              std::uint64_t draw_seed, double* h_out, double* pdf_out, double* wi_out) const;
  // The density per steradian of h with which sample() draws h at pixel i (0 below the horizon).
  void pdf(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed, double* out) const;
  // Per-facet colour (Algorithm 1, lines 17 and 20; docs/math/glinty_ndf.md#glinty-colour): each point
  // takes the entry floor(u n) of the palette (n RGB triples) from a random number u of its own cell,
  // so E[GlintColor] is the palette's mean. out3[3i..] = RGB of evaluate (compensation x the mean
  // colour) or of reference; the same realization as the scalar calls.
  void evaluate_rgb(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                    const double* palette, int n_colors, double* out3) const;
  void reference_rgb(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                     const double* palette, int n_colors, double* out3) const;
  // T(h) for m half vectors: xy[2i..] in the unit square (NaN for h_z <= 0, which T does not map).
  void map_points(const double* h, std::size_t m, double* xy) const;
  // The visible glints per pixel (docs/math/glinty_ndf.md#glinty-matched): roulette-weighted count of
  // the points in DB23's footprint ellipse whose normal lies within radius x sigma of T(h).
  void visible_counts(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                      double radius, double* out) const;
  // The point process lit by an extended light (docs/math/lighting.md#lighting-own-truths): the points of the
  // levels KPT25 sums at half vector h[3i..] (h selects the levels and their roulette, nothing else), inside
  // DB23's footprint ellipse (as visible_counts), each counted with its roulette weight. opt.lit_as kNormal:
  // a facet of normal T^-1 of its point in U, for the channel `hit` gives its mirror direction of the view
  // wo[3i..]; kLobe: its lobe of eq. 4 integrated over each light or region (lobes.hpp,
  // docs/math/lighting.md#lighting-lobes). counts[i * channels + c], radiance[i] (weighted sums), points[i]
  // (the weighted points in the ellipse). Cost: every point in the filter's box.
  void light_counts(const double* uv, const double* jac, const double* h, const double* wo, std::size_t m,
                    std::uint64_t seed, const lighting::LightHit& hit, const lighting::GlintLightOptions& opt,
                    double* counts, double* radiance, double* points) const;
  // The glinty D of the points light_counts counts at half vector h[3i..] (the same levels, roulette and
  // ellipse; no filter weights, no compensation): D(h) sum_i keep_i N(T(h); mu_i, alpha_* sqrt(D(h))) / K_P,
  // the point-light value their lobes tend to as a light shrinks (docs/math/lighting.md#lighting-lobes).
  void footprint_ndf(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                     double* out) const;
  // UV-free glints (KPT25 §3.3.6, docs/math/glinty_ndf.md#glinty-triplanar). Per pixel i: P[3i..] the
  // world position, dP[6i..] = (dP/dx, dP/dy) its screen derivatives, n[3i..] the normal (weights and
  // shading frame), h[3i..] the half vector in world space (normalised here; h.n <= 0 gives 0). Each
  // plane is the uv-mapped model of evaluate/reference with uv = two coordinates of P, J = their
  // derivatives, h in the frame of n; a point of plane i is kept with the roulette R(r, w_i) of its
  // own random number r, and the compensation is blended linearly with w_i.
  void evaluate_triplanar(const double* P, const double* dP, const double* n, const double* h, std::size_t m,
                          std::uint64_t seed, double* out) const;
  // out_points[i] (if not null): the points kept (sum of their roulette weights) in the truncated filters.
  void reference_triplanar(const double* P, const double* dP, const double* n, const double* h, std::size_t m,
                           std::uint64_t seed, double* out, double* out_points = nullptr) const;
  // Exact expectations over realizations and positions (as expected()); either pointer may be null.
  void expected_triplanar(const double* dP, const double* n, const double* h, std::size_t m, double* e_ref,
                          double* e_alg) const;
  // The blend weights of the three planes (yz, xz, xy) for a normal n (not necessarily unit).
  std::array<double, 3> triplanar_weights(const double n[3]) const;
  // E over r of R(r, w): the keep rate of the roulette (w in the interior, differs near 0 and 1 when
  // epsilon > 0; w for the linear blend).
  double keep_rate(double w) const;

  // T^-1: the half vector of a point (x, y) of the disk U.
  std::array<double, 3> inverse_map(double x, double y) const;

  // The pixel set-up (exposed for tests and the documentation's figures).
  GlintPixel pixel(const double* jac, const double* h, std::size_t index) const;
  // T(h) in the unit square and D(h): the map of §3.2 (exact uniformising map, docs/math/glinty_ndf.md).
  std::array<double, 3> map(const double h[3]) const;

 private:
  double level_sum(const GlintPixel& px, int level, double weight, double u, double v, std::uint64_t seed,
                   bool all_angular, double* points, const double* palette = nullptr, int n_colors = 0,
                   double* rgb = nullptr, double plane_weight = 1.0, std::uint32_t tag = 0,
                   double* kept = nullptr) const;
  // The planes of triplanar pixel i (those with a nonzero weight; their count) and h in the frame of n.
  int triplanar_planes(const double* P, const double* dP, const double* n, const double* h, std::size_t i,
                       TriplanarPlane planes[3], double h_t[3]) const;
  GlintPixel plane_pixel(const TriplanarPlane& pl, const double h_t[3], std::size_t i) const;
  void refuse_triplanar_options() const;
  // E[evaluate] / D(h) of one pixel whose points are kept at the rate plane_rho and whose compensation
  // is weighted by plane_w (1 and 1 for the uv-mapped model).
  double expected_alg(const GlintPixel& px, double plane_rho, double plane_w) const;
  double compensation(const GlintPixel& px, int level) const;
  void footprint(GlintPixel& px, const double* jac, std::size_t index) const;
  double disk_D(double x, double y) const;  // D(T^-1(x, y)), the target at a point of U
  // One point's lobe (centre (mx, my) in U, roulette weight keep) integrated over the lights of `view`:
  // adds its share of each channel to c and of the radiance to radiance.
  void lobe_counts(const kpt25::LobeView& view, double mx, double my, double keep, double* c, double& radiance) const;
  // Its lobe's rule over the annulus r0 <= |u - mu| <= r1 (kpt25_lights.cpp).
  void lobe_annulus(const kpt25::LobeView& view, double mx, double my, double r0, double r1, double keep, double* c,
                    double& radiance) const;
  double level_pdf(const GlintPixel& px, int level, double u, double v, std::uint64_t seed, double x, double y) const;
  double pixel_pdf(const GlintPixel& px, double u, double v, std::uint64_t seed, double x, double y) const;
  bool draw_from_block(const GlintPixel& px, int li, double u, double v, std::uint64_t seed, double xa, double ya,
                       CounterRng& rng, double& x, double& y) const;
  // dx dy / dOmega of T at the unit half vector h: (pi / 4) D(h)(h.n) for the maps that uniformise
  // D(h)(h.n) dOmega, (pi / 8) D(h) |M^T h| for the Lambert map (docs/math/glinty_ndf.md#glinty-lambert).
  double jacobian(double D, const double h[3]) const;
  // The maps and D for alpha_x != alpha_y (the isotropic code paths stay as they were, bit for bit).
  std::array<double, 3> map_aniso(const double h[3]) const;
  std::array<double, 3> inverse_map_aniso(double dx, double dy, double r2) const;
  double disk_D_aniso(double dx, double dy, double r2) const;
  bool aniso_ = false;
  bool glint_aniso_ = false;  // A_* != identity
  void refuse_glint_anisotropy(const char* what) const;
  Kpt25Params p_;
  double res_ = 0.0;           // sqrt(K_P): cells per unit uv at level 0 (per unit of x_s = A_* uv)
  double kp_ = 0.0;            // the density line 19 divides by (K_P; K_P / det A_* with anisotropic glints)
  double cells_per_uv_ = 0.0;  // level-0 spatial cells per unit uv along the most stretched axis
};

// The integral over the rectangle [x0, x1] x [y0, y1] intersected with the disk U (centre (1/2, 1/2),
// radius 1/2) of the normalised isotropic 2D Gaussian of std sigma centred at (cx, cy). A product of
// normal CDF differences when the disk does not cut the lobe; otherwise globally adaptive Gauss-Kronrod
// over the angle theta, x = (1 - cos theta) / 2, of the normal mass on the chord, at most 60 halvings
// (bounded cost; relative error about 1e-13 in the tests, docs/math/glinty_ndf.md#glinty-algorithm1).
double gaussian_in_disk_rect(double cx, double cy, double sigma, double x0, double x1, double y0, double y1);

// The area of the rectangle [x0, x1] x [y0, y1] intersected with the disk U (closed form).
double rect_disk_area(double x0, double x1, double y0, double y1);

// R(r, w) of KPT25 eq. 8: smoothstep(max(0, r - eps), min(1, r + eps), w); eps = 0 is the Heaviside w >= r.
double kpt25_roulette(double r, double w, double eps);

}  // namespace glintlab
