// An example glint method for extended lights, as a whole method shader (docs/math/lighting.md#lighting-shader):
// the count of a pixel's facets that mirror the view into the light, drawn by DB23's gated Gaussian
// (gated_body.h) at KK24's small-light probability p = D(h) (h.n) Omega / (4 (v.h)), h the half vector of
// the light's centre and Omega its solid angle (glintlab_light_solid_angle), on DB23's anisotropic grids as
// the DB23 method shader counts (db23_count of db23_method_body.h): the footprint's facets split over the
// cells it covers at two LOD levels, each cell's count from its own hashed uniforms, so neighbouring pixels
// share cells (no streaks along a grazing plane's rows) and a change of level is a blend, not a pop
// (docs/math/lighting.md#lighting-scene-cells). The value is the light's radiance times the share of lit facets, K / n:
// what the facet truth lit by the same light gives (the radiance of its lit facets over the footprint's n).
// Its twin is glintlab.validation.lighting_images.area_light_twin (the same steps in float64).
// The material comes as the NDF shaders' defines: GLINTLAB_DENSITY, GLINTLAB_ALPHA, GLINTLAB_GGX, and the
// angular texels per unit slope GLINTLAB_ANGULAR_RES (the cells' keys, as DB23_ANGULAR_RES).
#ifndef AREA_LIGHT_METHOD_BODY_H
#define AREA_LIGHT_METHOD_BODY_H

#ifndef GLINTLAB_DENSITY
#define GLINTLAB_DENSITY 4096.0
#endif
#ifndef GLINTLAB_ANGULAR_RES
#define GLINTLAB_ANGULAR_RES 20.0
#endif
#define DB23_DENSITY GLINTLAB_DENSITY
#define DB23_ANGULAR_RES GLINTLAB_ANGULAR_RES
#define DB23_COUNT_ONLY
#include "db23_method_body.h"
#ifndef GLINTLAB_ALPHA
#define GLINTLAB_ALPHA 1.0
#endif
#ifndef GLINTLAB_GGX
#define GLINTLAB_GGX 0
#endif

// D of the material at cos c (Beckmann, or GGX when GLINTLAB_GGX is 1).
float area_light_ndf(float c) {
  float a2 = GLINTLAB_ALPHA * GLINTLAB_ALPHA;
  float c2 = c * c;
#if GLINTLAB_GGX
  float q = (a2 - 1.0) * c2 + 1.0;
  return a2 / (3.14159265358979 * q * q);
#else
  return exp(-((1.0 - c2) / c2) / a2) / (3.14159265358979 * a2 * c2 * c2);
#endif
}

float glint(GlintInput g) {
  float3 v = normalize(g.view);
  float c = dot(g.h, g.n);
  float vh = dot(v, g.h);
#ifdef AREA_LIGHT_BUG_NO_SOLID_ANGLE
  float omega = 1.0;  // a deliberate bug for glintlab's tests: p read as the density, not times the light's size
#else
  float omega = glintlab_light_solid_angle(g);
#endif
  if (!(omega > 0.0) || !(c > 0.0) || !(vh > 0.0)) return 0.0;
  float p = min(area_light_ndf(c) * c * omega / (4.0 * vh), 1.0);
  float det = abs(g.J.x * g.J.w - g.J.y * g.J.z);
  float n = GLINTLAB_DENSITY * det;
  if (!(n > 0.0)) return 0.0;
  float3 ht = float3(dot(g.h, g.t), dot(g.h, g.b), dot(g.h, g.n));
  return g.light_radiance * db23_count(g, ht, p) / n;
}

#endif
