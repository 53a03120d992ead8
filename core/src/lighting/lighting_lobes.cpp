// The product rules of lobes.hpp (docs/math/lighting.md#lighting-lobes).
#include "glintlab/lighting/lobes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "glintlab/base/errors.hpp"

namespace glintlab::lighting {

namespace {

constexpr double kPi = std::numbers::pi;

}  // namespace

// Newton's iteration on P_n from Chebyshev guesses (n <= 256: it converges to rounding in a few steps).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(n, 0.0);
  w.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double t = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = t;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * t * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (t * p1 - p0) / (t * t - 1.0);
      const double step = p1 / dp;
      t -= step;
      if (std::abs(step) < 1e-15) break;
    }
    x[i] = t;
    w[i] = 2.0 / ((1.0 - t * t) * dp * dp);
  }
}

void LobeRule::check() const {
  if (!(rings >= 1 && rings <= 256))
    throw_invalid("lobe rule", "rings", static_cast<double>(rings), "an integer in [1, 256]");
  if (!(sectors >= 1 && sectors <= 256))
    throw_invalid("lobe rule", "sectors", static_cast<double>(sectors), "an integer in [1, 256]");
}

void tangent_frame(Vec3 c, Vec3& t1, Vec3& t2) {
  // The axis least aligned with c, made perpendicular to it.
  const Vec3 a = std::abs(c.x) < 0.6 ? Vec3{1, 0, 0} : (std::abs(c.y) < 0.6 ? Vec3{0, 1, 0} : Vec3{0, 0, 1});
  const double d = a.x * c.x + a.y * c.y + a.z * c.z;
  Vec3 u{a.x - d * c.x, a.y - d * c.y, a.z - d * c.z};
  const double n = std::sqrt(u.x * u.x + u.y * u.y + u.z * u.z);
  t1 = {u.x / n, u.y / n, u.z / n};
  t2 = {c.y * t1.z - c.z * t1.y, c.z * t1.x - c.x * t1.z, c.x * t1.y - c.y * t1.x};
}

Vec3 polar_direction(Vec3 c, Vec3 t1, Vec3 t2, double rho, double phi) {
  const double cr = std::cos(rho), sr = std::sin(rho), cp = std::cos(phi), sp = std::sin(phi);
  return {cr * c.x + sr * (cp * t1.x + sp * t2.x), cr * c.y + sr * (cp * t1.y + sp * t2.y),
          cr * c.z + sr * (cp * t1.z + sp * t2.z)};
}

double cap_ring_angle(int k, int rings, double gamma) {
  // The area within rho of the centre is 4 pi sin^2(rho / 2): equal areas in sin^2(rho / 2).
  return 2.0 * std::asin(std::sin(0.5 * gamma) * std::sqrt((k + 0.5) / rings));
}

namespace {

// The sectors' angles about the light's centre and their weights: equal sectors for a round light; for a
// parallelogram, Gauss-Legendre between consecutive corners (the edge ray rho_max(phi) is smooth there,
// kinked at the corners, which equal sectors would straddle). The horizon's kinks are not split.
void sector_angles(const Light& light, Vec3 t1, Vec3 t2, int sectors, std::vector<double>& phis,
                   std::vector<double>& weights) {
  phis.clear();
  weights.clear();
  const auto corners = light.corners();
  if (corners.empty()) {
    for (int s = 0; s < sectors; ++s) {
      phis.push_back(2.0 * kPi * (s + 0.5) / sectors);
      weights.push_back(2.0 * kPi / sectors);
    }
    return;
  }
  std::vector<double> cuts;
  for (const Vec3& p : corners)
    cuts.push_back(std::atan2(p.x * t2.x + p.y * t2.y + p.z * t2.z, p.x * t1.x + p.y * t1.y + p.z * t1.z));
  std::sort(cuts.begin(), cuts.end());
  cuts.push_back(cuts.front() + 2.0 * kPi);
  const int per_edge = std::max(2, (sectors + 1) / 2);  // a parallelogram's rule: half the sectors per edge
  std::vector<double> x, w;
  gauss_legendre(per_edge, x, w);
  for (std::size_t e = 0; e + 1 < cuts.size(); ++e)
    for (int g = 0; g < per_edge; ++g) {
      const double half = 0.5 * (cuts[e + 1] - cuts[e]);
      phis.push_back(cuts[e] + half * (1.0 + x[g]));
      weights.push_back(half * w[g]);
    }
}

}  // namespace

LightNodes light_nodes(const LightHit& hit, const LobeRule& rule) {
  rule.check();
  LightNodes out;
  if (hit.is_map()) return out;
  std::vector<double> gx, gw;
  gauss_legendre(rule.rings, gx, gw);
  const auto& lights = hit.lights();
  for (std::size_t k = 0; k < lights.size(); ++k) {
    out.first.push_back(static_cast<int>(out.dir.size()));
    const Vec3 c = lights[k].center();
    Vec3 t1, t2;
    tangent_frame(c, t1, t2);
    out.centre.push_back(c);
    out.t1.push_back(t1);
    out.t2.push_back(t2);
    out.exits.emplace_back();
    if (!(c.z > 0.0)) {
      out.phi.emplace_back();
      out.phi_weight.emplace_back();  // not star-shaped about its centre above the horizon: the lobe's rule only
      out.radius.push_back(std::numeric_limits<double>::infinity());
      out.last.push_back(static_cast<int>(out.dir.size()));
      continue;
    }
    double radius = 0.0;
    std::vector<double> phis, phi_w;
    sector_angles(lights[k], t1, t2, rule.sectors, phis, phi_w);
    for (std::size_t s = 0; s < phis.size(); ++s) {
      const double phi = phis[s];
      const Vec3 d{std::cos(phi) * t1.x + std::sin(phi) * t2.x, std::cos(phi) * t1.y + std::sin(phi) * t2.y,
                   std::cos(phi) * t1.z + std::sin(phi) * t2.z};
      const double rho_max = lights[k].exit(c, d, true);
      out.exits.back().push_back(rho_max);
      radius = std::max(radius, rho_max);
      for (int r = 0; r < rule.rings; ++r) {
        const double rho = 0.5 * rho_max * (1.0 + gx[r]);
        const Vec3 w = polar_direction(c, t1, t2, rho, phi);
        bool earlier = false;  // a direction lights the first light that holds it
        for (std::size_t j = 0; j < k && !earlier; ++j) earlier = lights[j].contains(w);
        if (earlier) continue;
        out.dir.push_back(w);
        out.weight.push_back(phi_w[s] * 0.5 * rho_max * gw[r] * std::sin(rho));
      }
    }
    out.phi.push_back(phis);
    out.phi_weight.push_back(phi_w);
    out.radius.push_back(radius);
    out.last.push_back(static_cast<int>(out.dir.size()));
  }
  return out;
}

}  // namespace glintlab::lighting
