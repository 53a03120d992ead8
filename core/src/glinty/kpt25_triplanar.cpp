// KPT25's UV-free (triplanar) glints, §3.3.6: three copies of the uv-mapped model blended by the
// roulette (glinty_ndf.hpp, docs/math/glinty_ndf.md#glinty-triplanar).
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"
#include "kpt25_internal.hpp"

namespace glintlab {

using namespace kpt25;  // NOLINT(google-build-using-namespace): this file's own helpers

// ---------------------------------------------------------------------------------------------------
// UV-free glints (KPT25 §3.3.6; docs/math/glinty_ndf.md#glinty-triplanar). Three copies of the
// uv-mapped model, one per coordinate plane of the world position, each with its footprint from the
// screen derivatives of its two coordinates, blended by a roulette on the weights w_i.

namespace {

// A dot product and the branchless orthonormal basis of Duff et al. 2017 (JCGT 6(1)) around a unit n:
// the shading frame the half vector is expressed in. For the isotropic targets any frame around n gives
// the same statistics; this one is continuous except where n_z changes sign (documented).
void frame_of(const double n[3], double t[3], double b[3]) {
  const double sign = std::copysign(1.0, n[2]);
  const double a = -1.0 / (sign + n[2]);
  const double c = n[0] * n[1] * a;
  t[0] = 1.0 + sign * n[0] * n[0] * a;
  t[1] = sign * c;
  t[2] = -sign * n[0];
  b[0] = c;
  b[1] = sign + n[1] * n[1] * a;
  b[2] = -n[1];
}

// A plane is dropped when its projected footprint has less than this fraction of the footprint's area
// (|dP/dx x dP/dy . e_i| / |dP/dx x dP/dy|): its MIP level and filter would be those of a line, and its
// weight is then at most about this fraction with normalised |n_i| weights (the weights are
// renormalised over the planes kept, so dropping one leaves the mean unchanged).
constexpr double kPlaneMinArea = 1e-6;

}  // namespace

void Kpt25Ndf::refuse_triplanar_options() const {
  refuse_glint_anisotropy("triplanar glints (the paper: no uv gradients to orient A_* by)");
  if (aniso_)
    throw_invalid(kWhere, "alpha_y", p_.alpha_y,
                  "alpha_y = alpha (isotropic roughness) for triplanar glints (no tangent frame to orient it by)");
}

std::array<double, 3> Kpt25Ndf::triplanar_weights(const double nin[3]) const {
  double n[3];
  if (!unit_vector(nin, n)) return {0.0, 0.0, 0.0};
  std::array<double, 3> w{};
  double sum = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double a = std::abs(n[c]);
    w[c] = p_.triplanar_sharpness == 1.0 ? a : std::pow(a, p_.triplanar_sharpness);
    sum += w[c];
  }
  if (p_.triplanar_weights != TriplanarWeights::printed)
    for (double& x : w) x /= sum;
  if (p_.triplanar_weights == TriplanarWeights::missing_xy) w[2] = 0.0;
  return w;
}

int Kpt25Ndf::triplanar_planes(const double* P, const double* dP, const double* n, const double* h, std::size_t i,
                               TriplanarPlane planes[3], double h_t[3]) const {
  static constexpr double kOrigin[3] = {0.0, 0.0, 0.0};  // P = nullptr: positions not needed (expectations)
  const double* p = P ? P + 3 * i : kOrigin;
  const double* d = dP + 6 * i;
  if (P) check_position("position", P, i, 3, cells_per_uv_);
  for (int c = 0; c < 6; ++c)
    if (!std::isfinite(d[c]) || std::abs(d[c]) > 1e12)
      throw_invalid(kWhere, element("dP", i, c), d[c], "a finite derivative, |dP| <= 1e12");
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(n[3 * i + c])) throw_invalid(kWhere, element("n", i, c), n[3 * i + c], "a finite normal");
    if (!std::isfinite(h[3 * i + c])) throw_invalid(kWhere, element("h", i, c), h[3 * i + c], "a finite half vector");
  }
  double nu[3], hu[3];
  if (!unit_vector(n + 3 * i, nu)) throw_invalid(kWhere, row_name("n", i), row_value(n + 3 * i, 3), "a nonzero normal");
  if (!unit_vector(h + 3 * i, hu))
    throw_invalid(kWhere, row_name("h", i), row_value(h + 3 * i, 3), "a nonzero half vector");
  double t[3], b[3];
  frame_of(nu, t, b);
  h_t[0] = hu[0] * t[0] + hu[1] * t[1] + hu[2] * t[2];
  h_t[1] = hu[0] * b[0] + hu[1] * b[1] + hu[2] * b[2];
  h_t[2] = hu[0] * nu[0] + hu[1] * nu[1] + hu[2] * nu[2];
  // The footprint's normal area vector dP/dx x dP/dy: its component along axis c is the det J of plane c.
  const double cr[3] = {d[1] * d[5] - d[2] * d[4], d[2] * d[3] - d[0] * d[5], d[0] * d[4] - d[1] * d[3]};
  const double area = std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  if (!(area > 0.0))
    throw_invalid(kWhere, row_name("dP", i), row_value(d, 6),
                  "screen derivatives with dP/dx x dP/dy != 0 (mask pixels that do not see the surface)");
  auto w = triplanar_weights(nu);
  static constexpr int kAxes[3][2] = {{1, 2}, {0, 2}, {0, 1}};  // the coordinates of the yz, xz, xy planes
  double kept_sum = 0.0;
  int count = 0;
  for (int c = 0; c < 3; ++c) {
    if (!(w[c] > 0.0) || !(std::abs(cr[c]) > kPlaneMinArea * area)) continue;
    if (p_.triplanar_weights == TriplanarWeights::missing_xy && c == 2) continue;
    TriplanarPlane& pl = planes[count++];
    pl.axis = c;
    pl.u = p[kAxes[c][0]];
    pl.v = p[kAxes[c][1]];
    pl.J[0] = d[kAxes[c][0]];      // du/dx
    pl.J[1] = d[kAxes[c][1]];      // dv/dx
    pl.J[2] = d[3 + kAxes[c][0]];  // du/dy
    pl.J[3] = d[3 + kAxes[c][1]];  // dv/dy
    pl.weight = w[c];
    pl.tag = p_.triplanar_shared_seeds ? 0u : static_cast<std::uint32_t>(c + 1);
    kept_sum += w[c];
  }
  // Renormalise over the planes kept (normalised weights only: the printed ones stay as printed, and the
  // deliberately wrong blend keeps its missing plane's share lost).
  const double full = w[0] + w[1] + w[2];
  if (p_.triplanar_weights == TriplanarWeights::normalized && kept_sum > 0.0 && kept_sum < full)
    for (int k = 0; k < count; ++k) planes[k].weight *= full / kept_sum;
  return count;
}

GlintPixel Kpt25Ndf::plane_pixel(const TriplanarPlane& pl, const double h_t[3], std::size_t i) const {
  try {
    return pixel(pl.J, h_t, 0);
  } catch (const std::invalid_argument& e) {  // name the caller's pixel and the plane
    static constexpr const char* kPlanes[3] = {"yz", "xz", "xy"};
    throw_invalid_message(std::string(e.what()) + " (triplanar pixel " + std::to_string(i) + ", " + kPlanes[pl.axis] +
                          " plane: J = the derivatives of its two coordinates of P)");
  }
}

void Kpt25Ndf::evaluate_triplanar(const double* P, const double* dP, const double* n, const double* h, std::size_t m,
                                  std::uint64_t seed, double* out) const {
  refuse_triplanar_options();
  detail::parallel_chunks(m, 32, 64, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      TriplanarPlane planes[3];
      double h_t[3];
      const int np = triplanar_planes(P, dP, n, h, i, planes, h_t);
      double value = 0.0;
      for (int k = 0; k < np; ++k) {
        const GlintPixel px = plane_pixel(planes[k], h_t, i);
        if (px.D == 0.0) continue;
        double explicit_sum = 0.0, comp = 0.0;
        for (int l = 0; l < px.n_levels; ++l) {
          explicit_sum += level_sum(px, px.levels[l], px.weights[l], planes[k].u, planes[k].v, seed, false, nullptr,
                                    nullptr, 0, nullptr, planes[k].weight, planes[k].tag);
          comp += px.weights[l] * compensation(px, px.levels[l]);
        }
        value += px.D * (explicit_sum / kp_ + planes[k].weight * comp);  // compensation blended linearly
      }
      out[i] = value;
    }
  });
}

void Kpt25Ndf::reference_triplanar(const double* P, const double* dP, const double* n, const double* h, std::size_t m,
                                   std::uint64_t seed, double* out, double* out_points) const {
  refuse_triplanar_options();
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      TriplanarPlane planes[3];
      double h_t[3];
      const int np = triplanar_planes(P, dP, n, h, i, planes, h_t);
      double value = 0.0, kept = 0.0;
      for (int k = 0; k < np; ++k) {
        const GlintPixel px = plane_pixel(planes[k], h_t, i);
        if (px.D == 0.0) continue;
        double sum = 0.0;
        for (int l = 0; l < px.n_levels; ++l)
          sum += level_sum(px, px.levels[l], px.weights[l], planes[k].u, planes[k].v, seed, true, nullptr, nullptr, 0,
                           nullptr, planes[k].weight, planes[k].tag, &kept);
        value += px.D * sum / kp_;
      }
      out[i] = value;
      if (out_points) out_points[i] = kept;
    }
  });
}

void Kpt25Ndf::expected_triplanar(const double* dP, const double* n, const double* h, std::size_t m, double* e_ref,
                                  double* e_alg) const {
  refuse_triplanar_options();
  detail::parallel_chunks(m, 4, 8, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      TriplanarPlane planes[3];
      double h_t[3];
      const int np = triplanar_planes(nullptr, dP, n, h, i, planes, h_t);  // positions do not enter
      double er = 0.0, ea = 0.0;
      for (int k = 0; k < np; ++k) {
        const GlintPixel px = plane_pixel(planes[k], h_t, i);
        if (px.D == 0.0) continue;
        const double rho = keep_rate(planes[k].weight);
        er += rho * px.D * gaussian_in_disk_rect(px.xa, px.ya, px.sigma, 0.0, 1.0, 0.0, 1.0);
        ea += px.D * expected_alg(px, rho, planes[k].weight);
      }
      if (e_ref) e_ref[i] = er;
      if (e_alg) e_alg[i] = ea;
    }
  });
}

}  // namespace glintlab
