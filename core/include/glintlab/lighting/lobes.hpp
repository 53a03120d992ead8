// The lobe of one glint integrated over an extended light (docs/math/lighting.md#lighting-lobes): KPT25's
// points spread over a Gaussian lobe (its eq. 4) and WWH18's flakes reflect within a cone of half-angle
// gamma (its eq. 3-4), so under a light a point or flake contributes the share of its lobe the light
// covers, not the indicator of its centre. Shared by Kpt25Ndf::light_counts and Wwh18Ndf::light_counts.
//
// Two deterministic product rules, chosen per (glint, light) by size (a smooth integrand wants nodes
// spread over the smaller of the two):
// - the lobe's rule: polar nodes about the lobe's centre (rings x sectors), each tested with LightHit (so
//   lights and a map's regions alike): KPT25's Gaussian by Gauss-Legendre in the radius up to
//   kLobeRadius stds (the mass beyond, exp(-18) = 1.5e-8, left out; kpt25_lights.cpp) times equal
//   sectors; WWH18's uniform cone by cells of equal solid angle. Smooth lobes fully inside a light are
//   integrated to ~1e-4 at 8 rings; the error is in the nodes near the light's edge.
// - the light's rule: Gauss-Legendre in the angle from the light's centre up to its edge (Light::exit,
//   clipped at the horizon) times sectors (equal, or Gauss-Legendre between a parallelogram's corners), the
//   lobe's density evaluated at each node: the rule of
//   lights smaller than the lobe, and of the point-light limit (lights only; a map uses the lobe's rule).
#pragma once

#include <vector>

#include "glintlab/lighting/lighting.hpp"

namespace glintlab::lighting {

// How a glint of a method with lobes is lit: as one normal (the indicator of its centre; the counting
// view) or as its lobe integrated over the light (the method's own model).
enum class GlintLight { kNormal, kLobe };

// Nodes of the product rules: rings x sectors for the lobe's rule, radial x sectors for the light's.
struct LobeRule {
  int rings = 8, sectors = 12;
  void check() const;  // std::invalid_argument naming "rings" or "sectors" (each in [1, 256])
};

// How light_counts lights the glints: `mirror` false tests the normal in place of its mirror direction and
// `unnormalised` drops the lobe's normalisation (KPT25: eq. 4's printed 1D factor 1 / (sigma sqrt(2 pi)) in
// place of the 2D density's 1 / (2 pi sigma^2); WWH18: the cone's 1 / sigma(gamma) left out): the
// deliberately wrong variants the tests reject.
struct GlintLightOptions {
  GlintLight lit_as = GlintLight::kLobe;
  LobeRule rule;
  bool mirror = true;
  bool unnormalised = false;
};

// The light's rule for every light of a LightHit (nothing for a map): node directions with their solid
// angles (directions inside an earlier light are left out: a direction lights the first light holding it,
// as LightHit::hit), the light of each, and per light its node range and its radius (the largest angle
// from its centre to its edge among the sectors).
struct LightNodes {
  std::vector<Vec3> dir;
  std::vector<double> weight;
  std::vector<int> first, last;  // nodes [first[k], last[k]) belong to light k
  std::vector<double> radius;
  // The rays behind the nodes, per light: its centre and tangent frame, and per sector the angle where
  // the ray leaves the light (clipped at the horizon): the rule of a lobe with an edge (WWH18's cone).
  std::vector<Vec3> centre, t1, t2;
  std::vector<std::vector<double>> phi, phi_weight, exits;  // per light, per sector
};
LightNodes light_nodes(const LightHit& hit, const LobeRule& rule);

// An orthonormal pair (t1, t2) perpendicular to the unit vector c.
void tangent_frame(Vec3 c, Vec3& t1, Vec3& t2);
// The unit direction at angle rho from c along the tangent cos(phi) t1 + sin(phi) t2.
Vec3 polar_direction(Vec3 c, Vec3 t1, Vec3 t2, double rho, double phi);
// The truncation radius (in stds) of the lobe's rule for a Gaussian.
inline constexpr double kLobeRadius = 6.0;
// Gauss-Legendre nodes and weights on [-1, 1] (n in [1, 256]).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w);
// The median angle of ring k (of `rings` of equal area) of a spherical cap of half-angle gamma.
double cap_ring_angle(int k, int rings, double gamma);

}  // namespace glintlab::lighting
