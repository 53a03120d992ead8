// KPT25's glinty NDF: the maps T, the pixel set-up, Algorithm 1 and the reference (glinty_ndf.hpp,
// docs/math/glinty_ndf.md). Algorithm 2 is in kpt25_sampling.cpp, the triplanar glints in
// kpt25_triplanar.cpp, the disk integrals in kpt25_disk.cpp, their shared helpers (the one enumeration
// of the point process) in kpt25_internal.hpp.
#include "glintlab/glinty/glinty_ndf.hpp"

#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <cstdint>
#include <string>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "kpt25_internal.hpp"

namespace glintlab {

namespace kpt25 {

void check_position(const char* name, const double* x, std::size_t i, int n, double cells_per_unit) {
  // The filter's box adds a few cells at the level in use: a margin of 2^-10 of the range is ample.
  const double limit = std::min(1e9, kMaxCellIndex * (1.0 - 0x1p-10) / cells_per_unit);
  for (int c = 0; c < n; ++c) {
    const double v = x[n * i + c];
    if (std::isfinite(v) && std::abs(v) <= limit) continue;
    if (limit == 1e9 || !std::isfinite(v))
      throw_invalid(kWhere, element(name, i, c), v, std::string("a finite position, |") + name + "| <= 1e9");
    throw_invalid(kWhere, element(name, i, c), v,
                  std::string("a position within 2^38 spatial cells of the origin (|") + name +
                      "| <= " + short_value(limit) + " at this density)");
  }
}

}  // namespace kpt25

using namespace kpt25;  // NOLINT(google-build-using-namespace): this file's own helpers

Kpt25Ndf::Kpt25Ndf(const Kpt25Params& params) : p_(params) {
  if (!(p_.density > 0.0 && p_.density <= 1e18)) throw_invalid(kWhere, "density", p_.density, "a number in (0, 1e18]");
  if (!(p_.alpha > 0.0 && std::isfinite(p_.alpha))) throw_invalid(kWhere, "alpha", p_.alpha, "a finite number > 0");
  if (!(p_.alpha_star >= 1e-30 && std::isfinite(p_.alpha_star)))
    throw_invalid(kWhere, "alpha_star", p_.alpha_star, "a finite number >= 1e-30");
  if (!(p_.k == 1 || p_.k == 4 || p_.k == 9 || p_.k == 16))
    throw_invalid(kWhere, "k", static_cast<double>(p_.k), "1, 4, 9 or 16 (a square block of angular cells)");
  if (!(p_.epsilon >= 0.0 && p_.epsilon <= 0.5)) throw_invalid(kWhere, "epsilon", p_.epsilon, "a number in [0, 0.5]");
  if (!(p_.filter > 0.0 && std::isfinite(p_.filter)))
    throw_invalid(kWhere, "filter", p_.filter, "a finite pixel filter std > 0 (pixels)");
  if (!(p_.sample_smooth >= 0.0 && p_.sample_smooth <= 1.0))
    throw_invalid(kWhere, "sample_smooth", p_.sample_smooth, "a probability in [0, 1]");
  if (!(p_.alpha_y == 0.0 || (p_.alpha_y > 0.0 && std::isfinite(p_.alpha_y))))
    throw_invalid(kWhere, "alpha_y", p_.alpha_y, "a finite number > 0 (or 0: isotropic)");
  aniso_ = p_.alpha_y > 0.0 && p_.alpha_y != p_.alpha;
  for (double a : {p_.glint_ax, p_.glint_ay})
    if (!(a >= 1e-3 && a <= 1e3)) throw_invalid(kWhere, "anisotropy", a, "stretches in [1e-3, 1e3]");
  glint_aniso_ = !(p_.glint_ax == 1.0 && p_.glint_ay == 1.0);
  if (glint_aniso_ && p_.compensation == GlintCompensation::disk)
    throw_invalid(kWhere, "compensation", std::string("disk"), "\"square\" or \"none\" with anisotropic glints");
  if (p_.lambert_printed_jacobian && !(p_.ggx_lambert && p_.target == GlintTarget::ggx))
    throw_invalid(kWhere, "lambert_jacobian", std::string("printed"), "\"map\" unless ggx_map is \"lambert\"");
  if (!(p_.triplanar_sharpness > 0.0 && p_.triplanar_sharpness <= 64.0))
    throw_invalid(kWhere, "triplanar_sharpness", p_.triplanar_sharpness, "a number in (0, 64]");
  res_ = std::sqrt(p_.density);
  if (glint_aniso_)  // cells per unit of x_s = A_* uv
    res_ = p_.glint_printed_density ? std::sqrt(p_.density) / (p_.glint_ax * p_.glint_ay)
                                    : std::sqrt(p_.density / (p_.glint_ax * p_.glint_ay));
  // Line 19's 1 / K_P: the points per unit area of x_s (K_P / det A_*) when the uv density is preserved,
  // so that E = D(h); K_P as printed (then E = D(h) / det(A_*)^2 with the printed resolution).
  kp_ = p_.density;
  if (glint_aniso_ && !p_.glint_printed_density) kp_ = p_.density / (p_.glint_ax * p_.glint_ay);
  // Level-0 spatial cells per unit of uv (x_s = A_* uv): the range the cells' random numbers cover.
  cells_per_uv_ = res_ * (glint_aniso_ ? std::max(p_.glint_ax, p_.glint_ay) : 1.0);
}

void Kpt25Ndf::refuse_glint_anisotropy(const char* what) const {
  if (glint_aniso_)
    throw_invalid(kWhere, "anisotropy", "(" + short_value(p_.glint_ax) + ", " + short_value(p_.glint_ay) + ")",
                  std::string("(1, 1) for ") + what + " (anisotropic glints: evaluate and reference only)");
}

// Anisotropic roughness: the stretch M = diag(1 / ax, 1 / ay, 1) of eq. 6 applied to the slopes
// (Beckmann) or to the half vector (GGX); the same constructions as the isotropic map below.
std::array<double, 3> Kpt25Ndf::map_aniso(const double h[3]) const {
  const double ax = p_.alpha, ay = p_.alpha_y, hx = h[0], hy = h[1], hz = h[2];
  double dx, dy, D;
  if (p_.target == GlintTarget::beckmann) {
    // Stretched slopes (s_x / ax, s_y / ay) are Gaussian with the isotropic law of alpha = 1; D =
    // exp(-t) / (pi ax ay cos^4), t = |stretched slope|^2.
    const double sx = hx / hz / ax, sy = hy / hz / ay, t = sx * sx + sy * sy;
    const double s2 = (hx * hx + hy * hy) / (hz * hz);
    if (!(t < 800.0)) {
      const double r = std::sqrt(sx * sx + sy * sy);
      return {0.5 + 0.5 * sx / r, 0.5 + 0.5 * sy / r, 0.0};
    }
    const double scale = t > 1e-300 ? std::sqrt(-std::expm1(-t) / t) : 1.0;
    dx = sx * scale;
    dy = sy * scale;
    D = std::exp(-t + 2.0 * std::log1p(s2)) / (kPi * ax * ay);
  } else {
    // GGX: D = 1 / (pi ax ay (hx^2 / ax^2 + hy^2 / ay^2 + hz^2)^2), the stretched normal cosine distributed.
    const double px = hx / ax, py = hy / ay, n2 = px * px + py * py + hz * hz, n = std::sqrt(n2);
    dx = px / n;
    dy = py / n;
    if (p_.ggx_lambert) {
      const double l = 1.0 / std::sqrt(1.0 + hz / n);
      dx *= l;
      dy *= l;
    }
    D = 1.0 / (kPi * ax * ay * n2 * n2);
  }
  return {0.5 + 0.5 * dx, 0.5 + 0.5 * dy, D};
}

std::array<double, 3> Kpt25Ndf::inverse_map_aniso(double dx, double dy, double r2) const {
  const double ax = p_.alpha, ay = p_.alpha_y;
  double v[3];
  if (p_.target == GlintTarget::beckmann) {
    const double ratio = r2 > 1e-300 ? std::sqrt(-std::log1p(-r2) / r2) : 1.0;
    v[0] = ax * dx * ratio;
    v[1] = ay * dy * ratio;
    v[2] = 1.0;
  } else if (p_.ggx_lambert) {
    const double l = std::sqrt(2.0 - r2);
    v[0] = ax * dx * l;
    v[1] = ay * dy * l;
    v[2] = 1.0 - r2;
  } else {
    v[0] = ax * dx;
    v[1] = ay * dy;
    v[2] = std::sqrt(std::max(0.0, 1.0 - r2));
  }
  double h[3];
  if (!unit_vector(v, h)) return {kNaN, kNaN, kNaN};
  return {h[0], h[1], h[2]};
}

double Kpt25Ndf::disk_D_aniso(double dx, double dy, double r2) const {
  const double ax = p_.alpha, ay = p_.alpha_y;
  if (p_.target == GlintTarget::beckmann) {
    // |s|^2 = (t / r2)(ax^2 dx^2 + ay^2 dy^2), t = -log(1 - r2); D = (1 - r2)(1 + |s|^2)^2 / (pi ax ay).
    const double t_r2 = r2 > 1e-300 ? -std::log1p(-r2) / r2 : 1.0;
    const double g = 1.0 + t_r2 * (ax * ax * dx * dx + ay * ay * dy * dy);
    return (1.0 - r2) * g * g / (kPi * ax * ay);
  }
  // The unstretched v = (ax w_x, ay w_y, w_z) of the unit stretched normal w: D = |v|^4 / (pi ax ay).
  double wx = dx, wy = dy, wz = std::sqrt(std::max(0.0, 1.0 - r2));
  if (p_.ggx_lambert) {
    const double l = std::sqrt(2.0 - r2);
    wx *= l;
    wy *= l;
    wz = 1.0 - r2;
  }
  const double v2 = ax * ax * wx * wx + ay * ay * wy * wy + wz * wz;
  return v2 * v2 / (kPi * ax * ay);
}

std::array<double, 3> Kpt25Ndf::map(const double hin[3]) const {
  double h[3];
  if (!unit_vector(hin, h) || !(h[2] > 0.0)) return {0.5, 0.5, 0.0};  // below the horizon: D = 0
  if (aniso_) return map_aniso(h);
  const double hx = h[0], hy = h[1], hz = h[2];
  const double a2 = p_.alpha * p_.alpha;
  double dx, dy, D;
  if (p_.target == GlintTarget::beckmann) {
    // Slopes s = (hx, hy) / hz are Gaussian (variance alpha^2 / 2 per axis) under D(h)(h.n)dh, so
    // |d|^2 = 1 - exp(-|s|^2 / alpha^2) is uniform and d = s |d| / |s| is uniform on the unit disk
    // (the inverse of §3.2.2's B1, Marsaglia's polar map). -expm1(-t)/t stays accurate as t -> 0.
    const double r2 = hx * hx + hy * hy;
    const double s2 = r2 / (hz * hz), t = s2 / a2;
    if (!(t < 800.0)) {
      // exp(-t) underflows: D = 0 and T(h) is on the rim, in the direction of (hx, hy) (the limit as
      // h_z -> 0; computing it through the slopes would give 0 x inf = NaN, or overflow).
      const double r = std::sqrt(r2);
      return {0.5 + 0.5 * hx / r, 0.5 + 0.5 * hy / r, 0.0};
    }
    const double scale = t > 1e-300 ? std::sqrt(-std::expm1(-t) / t) / p_.alpha : 1.0 / p_.alpha;
    dx = hx / hz * scale;
    dy = hy / hz * scale;
    // D = exp(-t) / (pi alpha^2 cos^4) with 1 / cos^4 = (1 + s^2)^2, in logs so that neither factor
    // overflows at grazing h.
    D = std::exp(-t + 2.0 * std::log1p(s2)) / (kPi * a2);
  } else {
    // GGX: the stretched half vector (hx / alpha, hy / alpha, hz), normalised, is cosine distributed
    // under D(h)(h.n)dh (§3.2.1's M~ with M = diag(1/alpha, 1/alpha, 1)); its orthographic projection
    // (x, y) is then uniform on the unit disk (docs/math/glinty_ndf.md#glinty-map: not the Lambert
    // projection of eq. 7, which makes a uniform hemisphere uniform, not a cosine-weighted one).
    const double px = hx / p_.alpha, py = hy / p_.alpha;
    const double n = std::sqrt(px * px + py * py + hz * hz);
    dx = px / n;
    dy = py / n;
    if (p_.ggx_lambert) {
      // Eq. 7: L(x, y, z) = (x, y) / sqrt(1 + z), |L|^2 = 1 - z on the unit hemisphere (equal-area).
      const double l = 1.0 / std::sqrt(1.0 + hz / n);
      dx *= l;
      dy *= l;
    }
    const double q = (a2 - 1.0) * hz * hz + 1.0;
    D = a2 / (kPi * q * q);
  }
  return {0.5 + 0.5 * dx, 0.5 + 0.5 * dy, D};
}

std::array<double, 3> Kpt25Ndf::inverse_map(double x, double y) const {
  const double dx = 2.0 * x - 1.0, dy = 2.0 * y - 1.0, r2 = dx * dx + dy * dy;
  if (!(r2 < 1.0)) return {kNaN, kNaN, kNaN};
  if (aniso_) return inverse_map_aniso(dx, dy, r2);
  double v[3];
  if (p_.target == GlintTarget::beckmann) {
    // |s|^2 = alpha^2 t with t = -log(1 - |d|^2) (the map above, inverted); t / |d|^2 -> 1 as d -> 0.
    const double ratio = r2 > 1e-300 ? std::sqrt(-std::log1p(-r2) / r2) : 1.0;
    v[0] = p_.alpha * dx * ratio;
    v[1] = p_.alpha * dy * ratio;
    v[2] = 1.0;
  } else if (p_.ggx_lambert) {  // L^-1: z = 1 - |d|^2, (x, y) = d sqrt(1 + z); then unstretched
    const double l = std::sqrt(2.0 - r2);
    v[0] = p_.alpha * dx * l;
    v[1] = p_.alpha * dy * l;
    v[2] = 1.0 - r2;
  } else {  // the stretched normal (dx, dy, sqrt(1 - |d|^2)), unstretched
    v[0] = p_.alpha * dx;
    v[1] = p_.alpha * dy;
    v[2] = std::sqrt(std::max(0.0, 1.0 - r2));
  }
  double h[3];
  if (!unit_vector(v, h)) return {kNaN, kNaN, kNaN};
  return {h[0], h[1], h[2]};
}

double Kpt25Ndf::disk_D(double x, double y) const {
  // D(T^-1(x, y)) without forming h: with r2 = |d|^2, Beckmann D = (1 - r2)(1 + alpha^2 t)^2 / (pi alpha^2),
  // t = -log(1 - r2); GGX D = (alpha^2 r2 + 1 - r2)^2 / (pi alpha^2).
  const double dx = 2.0 * x - 1.0, dy = 2.0 * y - 1.0, r2 = dx * dx + dy * dy;
  const double a2 = p_.alpha * p_.alpha;
  if (!(r2 < 1.0)) return 0.0;
  if (aniso_) return disk_D_aniso(dx, dy, r2);
  if (p_.target == GlintTarget::beckmann) {
    const double g = 1.0 - a2 * std::log1p(-r2);
    return (1.0 - r2) * g * g / (kPi * a2);
  }
  if (p_.ggx_lambert) {
    // The stretched normal has z = 1 - r2 and |(x, y)|^2 = 1 - z^2 = r2 (2 - r2); GGX D at its
    // unstretched h is (alpha^2 |(x, y)|^2 + z^2)^2 / (pi alpha^2).
    const double z = 1.0 - r2;
    const double g = a2 * r2 * (2.0 - r2) + z * z;
    return g * g / (kPi * a2);
  }
  const double g = a2 * r2 + 1.0 - r2;
  return g * g / (kPi * a2);
}

double Kpt25Ndf::jacobian(double D, const double h[3]) const {
  if (!(p_.target == GlintTarget::ggx && p_.ggx_lambert)) return 0.25 * kPi * D * h[2];
  // T = (1/2, 1/2) + L(M~(h)) / 2: M~(h) = M^T h / |M^T h| has the solid-angle Jacobian |det M| / |M^T h|^3
  // = pi D(h) |M^T h| (GGX: D = |det M| / (pi |M^T h|^4), M = diag(1 / alpha_x, 1 / alpha_y, 1)); Lambert's
  // L sends the hemisphere (area 2 pi) onto the unit disk (area pi), 1/2; the affine step scales by 1/4.
  // Eq. 6 prints the exponent 4 (the NDF's own transformation law), which gives (pi / 8) D(h).
  if (p_.lambert_printed_jacobian) return 0.125 * kPi * D;
  const double ay = aniso_ ? p_.alpha_y : p_.alpha;
  const double sx = h[0] / p_.alpha, sy = h[1] / ay;
  return 0.125 * kPi * D * std::sqrt(sx * sx + sy * sy + h[2] * h[2]);
}

void Kpt25Ndf::map_points(const double* h, std::size_t m, double* xy) const {
  detail::parallel_chunks(m, 256, 512, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double* H = h + 3 * i;
      double u[3];
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(H[c])) throw_invalid(kWhere, element("h", i, c), H[c], "a finite half vector");
      if (!unit_vector(H, u)) throw_invalid(kWhere, row_name("h", i), row_value(H, 3), "a nonzero half vector");
      if (!(u[2] > 0.0)) {
        xy[2 * i] = xy[2 * i + 1] = kNaN;  // below the horizon: T is not defined
        continue;
      }
      const auto t = map(H);
      xy[2 * i] = t[0];
      xy[2 * i + 1] = t[1];
    }
  });
}

void Kpt25Ndf::footprint(GlintPixel& px, const double* jac, std::size_t i) const {
  px.index = i;
  const double* J = jac + 4 * i;
  px.J = J;
  for (int c = 0; c < 4; ++c)
    if (!std::isfinite(J[c]) || std::abs(J[c]) > 1e12)
      throw_invalid(kWhere, element("J", i, c), J[c], "a finite derivative, |J| <= 1e12");
  double Js[4];
  if (glint_aniso_) {  // the footprint of x_s = A_* uv (Algorithm 1, line 2)
    Js[0] = p_.glint_ax * J[0];
    Js[1] = p_.glint_ay * J[1];
    Js[2] = p_.glint_ax * J[2];
    Js[3] = p_.glint_ay * J[3];
    J = Js;
  }
  // Spatial covariance f^2 J J^T (Algorithm 1, line 11) with J = [[du/dx, du/dy], [dv/dx, dv/dy]].
  const double f2 = p_.filter * p_.filter;
  const double suu = f2 * (J[0] * J[0] + J[2] * J[2]), svv = f2 * (J[1] * J[1] + J[3] * J[3]);
  const double suv = f2 * (J[0] * J[1] + J[2] * J[3]);
  const double detj = J[0] * J[3] - J[1] * J[2];
  const double det = f2 * f2 * detj * detj;
  if (!(det > 0.0) || !(det > 1e-24 * suu * svv))
    throw_invalid(kWhere, row_name("J", i), row_value(J, 4),
                  "a footprint with det J != 0 (here " + short_value(detj) +
                      ") and anisotropy below 1e12 (mask pixels that do not see the surface)");
  px.inv_a = svv / det;
  px.inv_b = -suv / det;
  px.inv_c = suu / det;
  px.norm = 1.0 / (2.0 * kPi * std::sqrt(det) * kFilterMass);
  px.half_u = kFilterRadius * std::sqrt(suu);
  px.half_v = kFilterRadius * std::sqrt(svv);
  // The level at which the filter's box (side 2 x 3 sigma_major) equals one cell (§3.3.2: the footprint
  // fits between once and twice the cell size): at most 3 x 3 cells at floor(lambda), 2 x 2 above.
  const double tr = suu + svv, disc = std::sqrt(std::max(0.0, 0.25 * (suu - svv) * (suu - svv) + suv * suv));
  const double major = std::sqrt(0.5 * tr + disc);
  px.lambda = std::log2(res_ * 2.0 * kFilterRadius * major);
  if (!(px.lambda <= kGlintMaxLevel))
    throw_invalid(kWhere, row_name("J", i), row_value(J, 4),
                  "a footprint small enough for the density (MIP level " + short_value(px.lambda) + " > " +
                      std::to_string(kGlintMaxLevel) + "; lower the density or the footprint)");
  px.lambda = std::max(0.0, px.lambda);
  const int l0 = static_cast<int>(std::floor(px.lambda));
  const double frac = px.lambda - l0;
  px.levels[0] = l0;
  if (frac > 0.0 && l0 < kGlintMaxLevel) {
    px.n_levels = 2;
    px.levels[1] = l0 + 1;
    px.weights[0] = 1.0 - frac;  // w_l = 1 - |lambda - l| (Algorithm 1, line 8)
    px.weights[1] = frac;
  }
}

GlintPixel Kpt25Ndf::pixel(const double* jac, const double* h, std::size_t i) const {
  GlintPixel px;
  const double* H = h + 3 * i;
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(H[c])) throw_invalid(kWhere, element("h", i, c), H[c], "a finite half vector");
  double unit_h[3];
  if (!unit_vector(H, unit_h)) throw_invalid(kWhere, row_name("h", i), row_value(H, 3), "a nonzero half vector");
  footprint(px, jac, i);
  const auto m = map(H);
  px.xa = m[0];
  px.ya = m[1];
  px.D = m[2];
  px.sigma = p_.alpha_star * std::sqrt(px.D);
  px.sigma_y = px.sigma;
  if (glint_aniso_) {  // Sigma_a = d (alpha_star A_*^-1)^2 (Algorithm 1, line 12)
    px.sigma_y = px.sigma / p_.glint_ay;
    px.sigma = px.sigma / p_.glint_ax;
    if (!(px.sigma_y * px.sigma_y > 1e-300)) px.D = 0.0;
  }
  // Where sigma^2 underflows (D(h) < 1e-240 at alpha_star >= 1e-30: the far grazing tail of Beckmann)
  // the lobes' 1 / (2 pi sigma^2) would give 0 x inf; the value D(h) x (a mass <= 1) is below 1e-240
  // there, and is returned as 0, the limit at grazing (docs/math/glinty_ndf.md#glinty-map).
  if (!(px.sigma * px.sigma > 1e-300)) px.D = 0.0;
  return px;
}

double Kpt25Ndf::level_sum(const GlintPixel& px, int level, double weight, double u, double v, std::uint64_t seed,
                           bool all_angular, double* points, const double* palette, int n_colors, double* rgb,
                           double plane_weight, std::uint32_t tag, double* kept) const {
  if (glint_aniso_) {  // x_s = A_* uv (Algorithm 1, line 2)
    u *= p_.glint_ax;
    v *= p_.glint_ay;
  }
  CellRange cells;
  if (all_angular) {
    cells = window_cells(px.xa, px.ya, px.reach * px.sigma, px.reach * px.sigma_y, level);
    const SpatialRange s = spatial_cells(res_, px, level, u, v);
    const double n_cells = static_cast<double>(s.i1 - s.i0 + 1) * static_cast<double>(s.j1 - s.j0 + 1) *
                           static_cast<double>(std::max<std::int64_t>(0, cells.a1 - cells.a0 + 1)) *
                           static_cast<double>(std::max<std::int64_t>(0, cells.b1 - cells.b0 + 1));
    if (n_cells > kGlintMaxReferenceCells)
      throw_invalid(kWhere, row_name("J", px.index), row_value(px.J, 4),
                    "a footprint whose reference sums at most 2e8 cells (this one: " + format_value(n_cells) +
                        " at level " + std::to_string(level) + "; lower the density or the footprint)");
  } else {
    cells = block_cells(px.xa, px.ya, level, p_.k);
  }
  const double inv2s2 = 0.5 / (px.sigma * px.sigma);
  const double inv2sx = inv2s2, inv2sy = 0.5 / (px.sigma_y * px.sigma_y);  // anisotropic glints
  double sum = 0.0, count = 0.0, kept_sum = 0.0, rgb_raw[3] = {0.0, 0.0, 0.0};
  for_each_point(res_, px, level, u, v, seed, tag, cells,
                 [&](std::int64_t i, std::int64_t j, std::int64_t a, std::int64_t b, double mx, double my, double q) {
                   count += 1.0;
                   const double keep = point_keep(p_, seed, level, i, j, a, b, weight, plane_weight, tag);
                   if (keep == 0.0) return;
                   kept_sum += keep;
                   const double ex = mx - px.xa, ey = my - px.ya;
                   const double term = glint_aniso_
                                           ? keep * px.norm * std::exp(-0.5 * q - ex * ex * inv2sx - ey * ey * inv2sy)
                                           : keep * px.norm * std::exp(-0.5 * q - (ex * ex + ey * ey) * inv2s2);
                   sum += term;
                   if (rgb) {  // GlintColor(i_s, i_a, l): the second word of the point's roulette block
                     const double cu = unit(point_block(seed, level, i, j, a, b, 1, tag)[1]);
                     const int idx = std::min(n_colors - 1, static_cast<int>(cu * n_colors));
                     for (int c = 0; c < 3; ++c) rgb_raw[c] += term * palette[3 * idx + c];
                   }
                 });
  if (points) *points += count;
  if (kept) *kept += kept_sum;
  // The angular Gaussian's normalisation 1 / (2 pi sigma^2) (a 2D density: eq. 4 prints the 1D one);
  // 1 / (2 pi sigma_x sigma_y) with anisotropic glints.
  const double norm_a = glint_aniso_ ? 2.0 * kPi * px.sigma * px.sigma_y : 2.0 * kPi * px.sigma * px.sigma;
  if (rgb)
    for (int c = 0; c < 3; ++c) rgb[c] += rgb_raw[c] / norm_a;
  return sum / norm_a;
}

double Kpt25Ndf::compensation(const GlintPixel& px, int level) const {
  if (p_.compensation == GlintCompensation::none) return 0.0;
  const CellRange block = block_cells(px.xa, px.ya, level, p_.k);
  const double inv = std::ldexp(1.0, -level);
  const double bx0 = static_cast<double>(block.a0) * inv, bx1 = static_cast<double>(block.a1 + 1) * inv;
  const double by0 = static_cast<double>(block.b0) * inv, by1 = static_cast<double>(block.b1 + 1) * inv;
  const double s = px.sigma;
  if (p_.compensation == GlintCompensation::disk) {  // eq. 9: U minus B(k)
    return gaussian_in_disk_rect(px.xa, px.ya, s, 0.0, 1.0, 0.0, 1.0) -
           gaussian_in_disk_rect(px.xa, px.ya, s, bx0, bx1, by0, by1);
  }
  // eq. 10: the unit square minus its part in B(k), products of 1D normal masses.
  const double sy = px.sigma_y;  // = s but with anisotropic glints
  const double square = mass_1d(px.xa, s, 0.0, 1.0) * mass_1d(px.ya, sy, 0.0, 1.0);
  const double in_b = mass_1d(px.xa, s, bx0, bx1) * mass_1d(px.ya, sy, by0, by1);
  return p_.compensation == GlintCompensation::square_flipped ? square + in_b : square - in_b;
}

void Kpt25Ndf::evaluate(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                        double* out) const {
  detail::parallel_chunks(m, 64, 128, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double u = uv[2 * i], v = uv[2 * i + 1];
      check_position("uv", uv, i, 2, cells_per_uv_);
      const GlintPixel px = pixel(jac, h, i);
      if (px.D == 0.0) {
        out[i] = 0.0;
        continue;
      }
      double explicit_sum = 0.0, comp = 0.0;
      for (int l = 0; l < px.n_levels; ++l) {
        explicit_sum += level_sum(px, px.levels[l], px.weights[l], u, v, seed, false, nullptr);
        comp += px.weights[l] * compensation(px, px.levels[l]);  // blended linearly (Fig. 5)
      }
      out[i] = px.D * (explicit_sum / kp_ + comp);  // eq. 11 with |J_T| read as D(h)
    }
  });
}

namespace {

// The reach (in lobe stds) of a reference with tolerance tol: a skipped cell lies more than r stds from
// T(h) along x or y, so each of its points' terms is below exp(-r^2 / 2) times its filter weight (keep x
// norm x exp(-q / 2)) over 2 pi sigma_x sigma_y; with exp(-r^2 / 2) / (2 pi sigma_x sigma_y) = tol the
// skipped terms add up to at most tol x the pixel's filter weight W summed over every point, i.e. the value
// D (sum) / K_P moves by at most tol x D(h) x W / K_P (docs/math/glinty_ndf.md#glinty-reference-reach).
// Never above the underflow radius, where the sum is already exact.
double reference_reach(const GlintPixel& px, double tol) {
  if (!(tol > 0.0)) return kUnderflowRadius;
  const double r2 = -2.0 * std::log(tol * 2.0 * kPi * px.sigma * px.sigma_y);
  return r2 > 0.0 ? std::min(kUnderflowRadius, std::sqrt(r2)) : 0.0;
}

}  // namespace

void Kpt25Ndf::reference(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                         double* out, double* out_points, double tol) const {
  if (!(tol >= 0.0 && tol < 1.0)) throw_invalid(kWhere, "tol", tol, "a tolerance in [0, 1) (0: the exact sum)");
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double u = uv[2 * i], v = uv[2 * i + 1];
      check_position("uv", uv, i, 2, cells_per_uv_);
      GlintPixel px = pixel(jac, h, i);
      px.reach = reference_reach(px, tol);
      double points = 0.0, sum = 0.0;
      if (px.D > 0.0)
        for (int l = 0; l < px.n_levels; ++l)
          sum += level_sum(px, px.levels[l], px.weights[l], u, v, seed, true, &points);
      out[i] = px.D * sum / kp_;
      if (out_points) out_points[i] = points;
    }
  });
}

double Kpt25Ndf::keep_rate(double w) const {
  // E over r of R(r, w): w for the linear blend and in the interior of the roulette; by quadrature at
  // the ends, where the clamps of eq. 8 make it differ from w (rho(w) + rho(1 - w) = 1 still holds).
  if (p_.blend == GlintBlend::linear || w >= 1.0 || w <= 0.0) return std::clamp(w, 0.0, 1.0);
  if (p_.epsilon == 0.0) return w;
  auto f = [&](double r) { return kpt25_roulette(r, w, p_.epsilon); };
  double total = 0.0;
  double cuts[] = {0.0,
                   std::clamp(w - p_.epsilon, 0.0, 1.0),
                   std::clamp(w + p_.epsilon, 0.0, 1.0),
                   std::min(p_.epsilon, 1.0),
                   std::max(0.0, 1.0 - p_.epsilon),
                   1.0};
  std::sort(std::begin(cuts), std::end(cuts));
  for (int c = 0; c + 1 < 6; ++c)
    if (cuts[c + 1] > cuts[c])
      total += boost::math::quadrature::gauss_kronrod<double, 15>::integrate(f, cuts[c], cuts[c + 1], 10, 1e-13);
  return total;
}

double Kpt25Ndf::expected_alg(const GlintPixel& px, double plane_rho, double plane_w) const {
  double total = 0.0;
  for (int l = 0; l < px.n_levels; ++l) {
    const CellRange block = block_cells(px.xa, px.ya, px.levels[l], p_.k);
    const double inv = std::ldexp(1.0, -px.levels[l]);
    const double in_b = gaussian_in_disk_rect(
        px.xa, px.ya, px.sigma, static_cast<double>(block.a0) * inv, static_cast<double>(block.a1 + 1) * inv,
        static_cast<double>(block.b0) * inv, static_cast<double>(block.b1 + 1) * inv);
    total += keep_rate(px.weights[l]) * plane_rho * in_b + px.weights[l] * plane_w * compensation(px, px.levels[l]);
  }
  return total;
}

void Kpt25Ndf::expected(const double* jac, const double* h, std::size_t m, double* e_ref, double* e_alg) const {
  refuse_glint_anisotropy("expected");
  detail::parallel_chunks(m, 4, 8, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const GlintPixel px = pixel(jac, h, i);
      if (px.D == 0.0) {
        if (e_ref) e_ref[i] = 0.0;
        if (e_alg) e_alg[i] = 0.0;
        continue;
      }
      const double in_disk = gaussian_in_disk_rect(px.xa, px.ya, px.sigma, 0.0, 1.0, 0.0, 1.0);
      if (e_ref) e_ref[i] = px.D * in_disk;  // rho(w) + rho(1 - w) = 1: the roulette keeps the mean
      if (e_alg) e_alg[i] = px.D * expected_alg(px, 1.0, 1.0);
    }
  });
}

// The visible glints of a pixel (docs/math/glinty_ndf.md#glinty-matched): the points inside DB23's
// footprint ellipse J {|x| <= 1 / sqrt(pi)} (area |det J|; q <= 1 / (pi f^2) in the filter's Mahalanobis
// distance) whose normal lies within `radius` lobe stds of T(h), each counted with its roulette weight
// R (both levels), so that the expected count is K_P |det J| times the area of the angular disk in U.
void Kpt25Ndf::visible_counts(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                              double radius, double* out) const {
  refuse_glint_anisotropy("visible_glints");
  const double q_max = point_filter_limit(p_.filter, "visible glint counts");
  if (!(radius > 0.0 && radius <= 10.0)) throw_invalid(kWhere, "radius", radius, "a number of lobe stds in (0, 10]");
  detail::parallel_chunks(m, 16, 32, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
      const GlintPixel px = pixel(jac, h, i);
      double count = 0.0;
      if (px.D > 0.0) {
        const double r = radius * px.sigma, r2 = r * r;
        for (int l = 0; l < px.n_levels; ++l) {
          const int level = px.levels[l];
          for_each_point(
              res_, px, level, uv[2 * i], uv[2 * i + 1], seed, 0, window_cells(px.xa, px.ya, r, r, level),
              [&](std::int64_t ci, std::int64_t cj, std::int64_t a, std::int64_t b, double mx, double my, double q) {
                const double ex = mx - px.xa, ey = my - px.ya;
                if (q <= q_max && ex * ex + ey * ey < r2)
                  count += point_keep(p_, seed, level, ci, cj, a, b, px.weights[l]);
              });
        }
      }
      out[i] = count;
    }
  });
}

void Kpt25Ndf::evaluate_rgb(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                            const double* palette, int n_colors, double* out3) const {
  if (n_colors < 1) throw_invalid(kWhere, "colors", static_cast<double>(n_colors), "at least one RGB colour");
  double mean[3] = {0.0, 0.0, 0.0};  // E[GlintColor] (Algorithm 1, line 20): each entry equally likely
  for (int k = 0; k < n_colors; ++k)
    for (int c = 0; c < 3; ++c) mean[c] += palette[3 * k + c] / n_colors;
  detail::parallel_chunks(m, 64, 128, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
      const GlintPixel px = pixel(jac, h, i);
      double* o = out3 + 3 * i;
      o[0] = o[1] = o[2] = 0.0;
      if (px.D == 0.0) continue;
      double rgb[3] = {0.0, 0.0, 0.0}, comp = 0.0;
      for (int l = 0; l < px.n_levels; ++l) {
        level_sum(px, px.levels[l], px.weights[l], uv[2 * i], uv[2 * i + 1], seed, false, nullptr, palette, n_colors,
                  rgb);
        comp += px.weights[l] * compensation(px, px.levels[l]);
      }
      for (int c = 0; c < 3; ++c) o[c] = px.D * (rgb[c] / kp_ + comp * mean[c]);
    }
  });
}

void Kpt25Ndf::reference_rgb(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                             const double* palette, int n_colors, double* out3) const {
  if (n_colors < 1) throw_invalid(kWhere, "colors", static_cast<double>(n_colors), "at least one RGB colour");
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
      const GlintPixel px = pixel(jac, h, i);
      double rgb[3] = {0.0, 0.0, 0.0};
      if (px.D > 0.0)
        for (int l = 0; l < px.n_levels; ++l)
          level_sum(px, px.levels[l], px.weights[l], uv[2 * i], uv[2 * i + 1], seed, true, nullptr, palette, n_colors,
                    rgb);
      for (int c = 0; c < 3; ++c) out3[3 * i + c] = px.D * rgb[c] / kp_;
    }
  });
}

}  // namespace glintlab
