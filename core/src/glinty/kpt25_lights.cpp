// KPT25's point process lit by an extended light (docs/math/lighting.md#lighting-own-truths): every point in
// the footprint is a facet whose normal is T^-1 of its point in the disk U, tested with the lighting
// module's one "mirror direction hits the light" (LightHit), or, as KPT25's eq. 4 models it, a Gaussian
// lobe in U integrated over each light (lobes.hpp, docs/math/lighting.md#lighting-lobes).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "glintlab/lighting/lobes.hpp"
#include "kpt25_internal.hpp"

namespace glintlab {

namespace kpt25 {

// One pixel's view of the lights: the light's rule's nodes seen through the view v (T of their half
// vectors, the lobe's 1 / (2 sigma^2) there and the node's factor: its solid angle x (pi/4) D(h)(h.n) /
// (4 v.h) / the Gaussian's normalisation), and the lobe's rule's ring radii (unit std) and sector angles.
struct LobeView {
  const lighting::LightHit* hit = nullptr;
  const lighting::GlintLightOptions* opt = nullptr;
  const lighting::LightNodes* nodes = nullptr;
  lighting::Vec3 v;
  std::vector<double> nx, ny, inv2s2, factor;
  std::vector<double> gl_x, gl_w, cos_phi, sin_phi;
  double sigma_max = 0.0;                // alpha_star sqrt(max D over U): how far a lobe of eq. 4 can reach
  mutable std::vector<char> light_rule;  // per light: this point uses the light's rule
};

}  // namespace kpt25

using namespace kpt25;

namespace {

constexpr double kLobeStds = 4.0;  // the lobe's radius (in stds) that the choice of rule compares with a light's

void view_nodes(const Kpt25Ndf& g, double alpha_star, LobeView& view) {
  const auto& nodes = *view.nodes;
  const std::size_t n = nodes.dir.size();
  view.nx.assign(n, 0.0);
  view.ny.assign(n, 0.0);
  view.inv2s2.assign(n, 0.0);
  view.factor.assign(n, 0.0);
  const auto v = view.v;
  for (std::size_t k = 0; k < n; ++k) {
    const auto w = nodes.dir[k];
    const double s[3] = {v.x + w.x, v.y + w.y, v.z + w.z};
    double h[3];
    if (!unit_vector(s, h)) continue;
    const double vh = v.x * h[0] + v.y * h[1] + v.z * h[2];
    if (!(vh > 0.0) || !(h[2] > 0.0)) continue;
    const auto t = g.map(h);
    const double s2 = alpha_star * alpha_star * t[2];
    if (!(s2 > 1e-300)) continue;
    const double norm = view.opt->unnormalised ? std::sqrt(2.0 * kPi * s2) : 2.0 * kPi * s2;
    view.nx[k] = t[0];
    view.ny[k] = t[1];
    view.inv2s2[k] = 0.5 / s2;
    view.factor[k] = nodes.weight[k] * 0.25 * kPi * t[2] * h[2] / (4.0 * vh) / norm;
  }
}

}  // namespace

void Kpt25Ndf::lobe_counts(const LobeView& view, double mx, double my, double keep, double* c, double& radiance) const {
  const auto& hit = *view.hit;
  const auto& opt = *view.opt;
  const auto v = view.v;
  const double d0 = disk_D(mx, my), s0 = p_.alpha_star * std::sqrt(d0);
  const auto h0 = inverse_map(mx, my);
  if (!(s0 * s0 > 1e-300) || !std::isfinite(h0[0])) {  // a lobe too narrow for doubles: its centre alone
    double rad = 0.0;
    const int k = hit.hit(v, {h0[0], h0[1], h0[2]}, rad, opt.mirror);
    if (k >= 0) {
      c[k] += keep;
      radiance += keep * rad;
    }
    return;
  }
  const double vh0 = v.x * h0[0] + v.y * h0[1] + v.z * h0[2], jt0 = jacobian(d0, h0.data());
  // The lobe's radius in directions of light: dwi / du = 4 (v.h) / |J_T| at its centre.
  const double r_lobe =
      vh0 > 0.0 && jt0 > 0.0 ? kLobeStds * s0 * std::sqrt(4.0 * vh0 / jt0) : std::numeric_limits<double>::infinity();
  const int lights = hit.is_map() ? 0 : static_cast<int>(hit.lights().size());
  bool any_lobe_rule = lights == 0 || !opt.mirror;
  for (int k = 0; k < lights; ++k) {
    view.light_rule[k] = opt.mirror && view.nodes->radius[k] < r_lobe;
    if (!view.light_rule[k]) {
      any_lobe_rule = true;
      continue;
    }
    double s = 0.0;
    for (int n = view.nodes->first[k]; n < view.nodes->last[k]; ++n) {
      const double ex = view.nx[n] - mx, ey = view.ny[n] - my;
      if (view.factor[n] != 0.0) s += view.factor[n] * std::exp(-(ex * ex + ey * ey) * view.inv2s2[n]);
    }
    c[k] += keep * s;
    radiance += keep * s * hit.light_radiance(k);
  }
  if (!any_lobe_rule) return;
  // The lobe's rule about mu: Gauss-Legendre in the radius over [0, 6 s0], s0 = sigma(mu), and over
  // [6 s0, 6 sigma_max] where sigma grows away from mu (eq. 4 takes the lobe's std at the evaluation point u,
  // so a point where D is small still reaches u where D is large: the points near U's rim for Beckmann);
  // each node weighted by eq. 4's lobe N(u; mu, sigma(u)) times (pi/4) D(h)(h.n) / |J_T(h)| (1 but for the
  // Lambert map) and its area rho d(rho) d(phi).
  // The outer annulus is skipped where it holds less than 1e-6 of the lobe: with sigma(u) <= sigma_max and
  // 6 s0 >= sqrt(2) sigma_max, the lobe beyond 6 s0 is at most exp(-18 s0^2 / sigma_max^2), below 1e-6
  // for s0 > 0.876 sigma_max.
  const double r_in = lighting::kLobeRadius * s0, r_out = lighting::kLobeRadius * view.sigma_max;
  lobe_annulus(view, mx, my, 0.0, r_in, keep, c, radiance);
  if (s0 < 0.876 * view.sigma_max) lobe_annulus(view, mx, my, r_in, r_out, keep, c, radiance);
}

void Kpt25Ndf::lobe_annulus(const LobeView& view, double mx, double my, double r0, double r1, double keep, double* c,
                            double& radiance) const {
  const auto& opt = *view.opt;
  const int rings = opt.rule.rings, sectors = opt.rule.sectors;
  const int lights = view.hit->is_map() ? 0 : static_cast<int>(view.hit->lights().size());
  for (int r = 0; r < rings; ++r) {
    const double rho = r0 + 0.5 * (r1 - r0) * (1.0 + view.gl_x[r]);
    const double area = 0.5 * (r1 - r0) * view.gl_w[r] * rho * 2.0 * kPi / sectors;
    for (int s = 0; s < sectors; ++s) {
      const double ux = mx + rho * view.cos_phi[s], uy = my + rho * view.sin_phi[s];
      const double d = disk_D(ux, uy), su2 = p_.alpha_star * p_.alpha_star * d;
      if (!(su2 > 1e-300)) continue;  // outside U (or where the lobe underflows): no half vector
      const auto h = inverse_map(ux, uy);
      if (!std::isfinite(h[0])) continue;
      // eq. 4's lobe at u: the 2D density 1 / (2 pi sigma^2), or the printed 1 / (sigma sqrt(2 pi)).
      const double norm = opt.unnormalised ? std::sqrt(2.0 * kPi * su2) : 2.0 * kPi * su2;
      const double w = area * std::exp(-0.5 * rho * rho / su2) / norm * 0.25 * kPi * d * h[2] / jacobian(d, h.data());
      if (w == 0.0) continue;
      double rad = 0.0;
      const int k = view.hit->hit(view.v, {h[0], h[1], h[2]}, rad, opt.mirror);
      if (k < 0 || (k < lights && view.light_rule[k])) continue;
      c[k] += keep * w;
      radiance += keep * w * rad;
    }
  }
}

void Kpt25Ndf::light_counts(const double* uv, const double* jac, const double* h, const double* wo, std::size_t m,
                            std::uint64_t seed, const lighting::LightHit& hit, const lighting::GlintLightOptions& opt,
                            double* counts, double* radiance, double* points) const {
  refuse_glint_anisotropy("light_counts");
  const double q_max = point_filter_limit(p_.filter, "light counts");
  const bool lobes = opt.lit_as == lighting::GlintLight::kLobe;
  const lighting::LightNodes nodes = lobes ? lighting::light_nodes(hit, opt.rule) : lighting::LightNodes{};
  const int channels = hit.channels();
  // max D over U on a 129 x 129 grid (D is smooth; the grid's max is within a fraction of a percent of it).
  double d_max = 0.0;
  for (int a = 0; a <= 128 && lobes; ++a)
    for (int b = 0; b <= 128; ++b) d_max = std::max(d_max, disk_D(a / 128.0, b / 128.0));
  const double sigma_max = p_.alpha_star * std::sqrt(d_max);
  detail::parallel_chunks(m, 1, 4, [&](std::size_t first, std::size_t last) {
    LobeView view;
    view.hit = &hit;
    view.opt = &opt;
    view.nodes = &nodes;
    view.light_rule.assign(hit.is_map() ? 0 : hit.lights().size(), 0);
    lighting::gauss_legendre(opt.rule.rings, view.gl_x, view.gl_w);
    view.sigma_max = sigma_max;
    for (int s = 0; s < opt.rule.sectors; ++s) {
      view.cos_phi.push_back(std::cos(2.0 * kPi * (s + 0.5) / opt.rule.sectors));
      view.sin_phi.push_back(std::sin(2.0 * kPi * (s + 0.5) / opt.rule.sectors));
    }
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
      double v[3];
      if (!unit_vector(wo + 3 * i, v) || !(v[2] > 0.0))
        throw_invalid(kWhere, element("wo", i, 2), wo[3 * i + 2], "a finite view above the horizon");
      const GlintPixel px = pixel(jac, h, i);
      view.v = {v[0], v[1], v[2]};
      if (lobes) view_nodes(*this, p_.alpha_star, view);
      double* c = counts + i * static_cast<std::size_t>(channels);
      for (int k = 0; k < channels; ++k) c[k] = 0.0;
      radiance[i] = points[i] = 0.0;
      for (int l = 0; l < px.n_levels; ++l) {
        const int level = px.levels[l];
        const std::int64_t na = std::int64_t{1} << level;
        const CellRange all{0, na - 1, 0, na - 1};
        const SpatialRange s = spatial_cells(res_, px, level, uv[2 * i], uv[2 * i + 1]);
        const double n_cells = static_cast<double>(s.i1 - s.i0 + 1) * static_cast<double>(s.j1 - s.j0 + 1) *
                               static_cast<double>(na) * static_cast<double>(na);
        if (n_cells > kGlintMaxReferenceCells)
          throw_invalid(kWhere, row_name("J", i), row_value(jac + 4 * i, 4),
                        "a footprint whose light counts visit at most 2e8 cells (this one: " + format_value(n_cells) +
                            " at level " + std::to_string(level) + "; lower the density or the footprint)");
        for_each_point(
            res_, px, level, uv[2 * i], uv[2 * i + 1], seed, 0, all,
            [&](std::int64_t ci, std::int64_t cj, std::int64_t a, std::int64_t b, double mx, double my, double q) {
              if (q > q_max) return;
              const double keep = point_keep(p_, seed, level, ci, cj, a, b, px.weights[l]);
              if (keep == 0.0) return;
              points[i] += keep;
              if (lobes) {
                lobe_counts(view, mx, my, keep, c, radiance[i]);
                return;
              }
              const auto n = inverse_map(mx, my);
              double rad = 0.0;
              const int k = hit.hit({v[0], v[1], v[2]}, {n[0], n[1], n[2]}, rad, opt.mirror);
              if (k < 0) return;
              c[k] += keep;
              radiance[i] += keep * rad;
            });
      }
    }
  });
}

void Kpt25Ndf::footprint_ndf(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                             double* out) const {
  refuse_glint_anisotropy("footprint_ndf");
  const double q_max = point_filter_limit(p_.filter, "light counts");
  detail::parallel_chunks(m, 4, 8, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
      const GlintPixel px = pixel(jac, h, i);
      double sum = 0.0;
      if (px.D > 0.0) {
        // Lobes beyond 10 stds add less than exp(-50) = 2e-22 of their peak each: left out.
        const double r = 10.0 * px.sigma, inv2s2 = 0.5 / (px.sigma * px.sigma);
        for (int l = 0; l < px.n_levels; ++l) {
          const int level = px.levels[l];
          for_each_point(
              res_, px, level, uv[2 * i], uv[2 * i + 1], seed, 0, window_cells(px.xa, px.ya, r, r, level),
              [&](std::int64_t ci, std::int64_t cj, std::int64_t a, std::int64_t b, double mx, double my, double q) {
                if (q > q_max) return;
                const double ex = mx - px.xa, ey = my - px.ya;
                sum +=
                    point_keep(p_, seed, level, ci, cj, a, b, px.weights[l]) * std::exp(-(ex * ex + ey * ey) * inv2s2);
              });
        }
      }
      out[i] = px.D * sum / (2.0 * kPi * px.sigma * px.sigma) / kp_;
    }
  });
}

}  // namespace glintlab
