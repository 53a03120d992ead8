// DB23's counting pipeline as a whole method shader (docs/math/glint_images.md#glint-db23-shader): per
// pixel, from GlintInput's uv, J, shading frame and h, the glinty NDF value
//     D_P = (D(n) / R) K / (N P),   P = |det J|                                     (DB23 eq. 3-4)
// with K counted on DB23's anisotropic virtual grids (§5.2, trilinear over the (scale, ratio,
// orientation) cell: 6 or 8 grids) by their gated Gaussian as their public shader runs it (the law body
// gated_body.h, shared with the law shaders). The method returns D, not an intensity: glintlab shades it
// with the microfacet BRDF as it does every NDF method.
//
// Its C++ twin is glintlab's DB23 glinty NDF with scheme "db23_trilinear" and inner law "gated_shader"
// (the C++ emulation of gated_body.h). To agree with it row by row the shader reads the SAME random
// numbers: each grid cell's two uniforms come from the core's splitmix64 keys (grid key from the seed and
// the grid's (scale, ratio, orientation) levels, texel key from the angular texel, cell input from the
// cell's integer coordinates), computed here in 64-bit arithmetic emulated on pairs of 32-bit words (no
// shaderInt64 needed), and converted to float32 exactly as the C++ double uniform converts. Everything
// else is float32 where the twin computes in double: the footprint's SVD, the level selection, the grid
// coordinates. Those are the documented float32 effects.
//
// Defines (the material; glintlab passes them): DB23_DENSITY N, DB23_ALPHA, DB23_R, DB23_GGX (0:
// Beckmann, 1: GGX), DB23_ANGULAR_RES (angular texels per unit slope). For the tests' deliberately
// wrong variants: DB23_LOD_BIAS (scale levels added to the selected level) and DB23_KEY_SALT (xored
// into the seed's grid keys).
#ifndef DB23_METHOD_BODY_H
#define DB23_METHOD_BODY_H

#include "gated_body.h"
#include "glintlab_rng.h"

#ifndef DB23_DENSITY
#define DB23_DENSITY 4194304.0
#endif
#ifndef DB23_ALPHA
#define DB23_ALPHA 1.0
#endif
#ifndef DB23_R
#define DB23_R 0.5
#endif
#ifndef DB23_GGX
#define DB23_GGX 0
#endif
#ifndef DB23_ANGULAR_RES
#define DB23_ANGULAR_RES 20.0
#endif
#ifndef DB23_LOD_BIAS
#define DB23_LOD_BIAS 0
#endif
#ifndef DB23_KEY_SALT
#define DB23_KEY_SALT 0u
#endif
#ifndef DB23_RANDOM_TEXTURE
#define DB23_RANDOM_TEXTURE 0  // 0: each cell's two uniforms hashed; 1: read from DB23RandomTex
#endif
#ifndef DB23_RANDOM_TILE
#define DB23_RANDOM_TILE 64    // DB23RandomTex's size (square), when DB23_RANDOM_TEXTURE is 1
#endif

// DB23's public shaders read their random numbers from a texture of precomputed ones rather than hashing
// them. DB23_RANDOM_TEXTURE 1 does so: DB23RandomTex (DB23_RANDOM_TILE^2 texels, two channels: the
// cell's two uniforms in (0, 1)) is read without filtering at the cell's coordinates, offset per grid
// and angular texel by the same key the hashed form derives the numbers from, so that grids and texels
// tile the texture differently (glintlab.api.counting_shaders.db23_method(random_texture=...)).
#if DB23_RANDOM_TEXTURE == 1
#if defined(GLINTLAB_GLSL)
uniform sampler2D DB23RandomTex;
#define DB23_RANDOM(x, y) texelFetch(DB23RandomTex, ivec2((x), (y)), 0).xy
#else
Texture2D<float2> DB23RandomTex;
#define DB23_RANDOM(x, y) DB23RandomTex.Load(int3((x), (y), 0)).xy
#endif
#endif

// ---- DB23's pipeline -----------------------------------------------------------------------------
#define DB23_PI 3.14159265358979
#define DB23_STEP1 0.392699081698724  // 22.5 degrees: the orientation step at ratio level 1
#define DB23_MAX_LEVEL 20                // ratios up to 2^20 (the scheme's max_ratio)

// Per term: the grid's levels and trial count, the pixel's grid coordinates, and the count.
float db23_term(int scale, int ratio, int orientation, float area, float weight, float2 uv, int2 texel, float p,
                uint2 seed_key) {
  int norient = ratio == 0 ? 1 : (8 << (ratio - 1));
  orientation = ((orientation % norient) + norient) % norient;
  float angle = ratio == 0 ? 0.0 : float(orientation) * GLINTLAB_LDEXP(DB23_STEP1, 1 - ratio);
  float cell_minor = sqrt(area);
  float cell_major = GLINTLAB_LDEXP(cell_minor, ratio);
  float cell_area = GLINTLAB_LDEXP(area, ratio);
  float trials = weight * DB23_DENSITY * cell_area;
  float c = cos(angle), s = sin(angle);
  // The quarter turn: the twin's double angle is pi/2 rounded, whose cosine is 6.1e-17, not 0; the shader
  // takes that value too, so that a column at u = 0 (a scene's axis) reads the twin's cells, not their
  // neighbours across X = 0 (float32's cos of the rounded quarter turn is -4.4e-8).
  if (ratio > 0 && 2 * orientation == norient) {
    c = 6.123234e-17;
    s = 1.0;
  }
  float X = (-uv.x * s + uv.y * c) / cell_minor;
  float Y = (uv.x * c + uv.y * s) / cell_major;
  int2 cell = int2(int(clamp(floor(X), -2147483520.0, 2147483520.0)), int(clamp(floor(Y), -2147483520.0, 2147483520.0)));
  // grid key (seed, scale, ratio, orientation), then the angular texel's key, then the cell's input
  uint2 key = glintlab_hash_combine(seed_key, glintlab_u64_from_int(scale));
  key = glintlab_hash_combine(key, glintlab_u64_from_int(ratio));
  key = glintlab_hash_combine(key, glintlab_u64_from_int(orientation));
  uint2 ta = glintlab_u64_mul(glintlab_u64_from_int(texel.x), uint2(0xA0B428DBu, 0xE7037ED1u));
  uint2 tb = glintlab_u64_mul(glintlab_u64_from_int(texel.y), uint2(0x9C88C6E3u, 0x8EBC6AF0u));
  key = glintlab_mix64(glintlab_u64_add(glintlab_u64_add(key, ta), tb));
  uint2 ca = glintlab_u64_mul(glintlab_u64_from_int(cell.x), uint2(0xD192ED03u, 0xD1B54A32u));
  uint2 cb = glintlab_u64_mul(glintlab_u64_from_int(cell.y), uint2(0xFB8FAC03u, 0xABC98388u));
#if DB23_RANDOM_TEXTURE == 1
  int tile = DB23_RANDOM_TILE;
  int tx = ((cell.x % tile) + tile + int(key.x % uint(tile))) % tile;
  int ty = ((cell.y % tile) + tile + int(key.y % uint(tile))) % tile;
  float2 r = DB23_RANDOM(tx, ty);
  float u0 = r.x;
  float u1 = r.y;
#else
  uint2 input_ = glintlab_u64_add(glintlab_u64_add(key, ca), cb);
  uint2 h = glintlab_mix64(input_);
  float u0 = glintlab_unit53(h);
  float u1 = glintlab_unit53(glintlab_mix64(glintlab_u64_add(h, uint2(0x2F3D8DD7u, 0x8CB92BA7u))));
#endif
  return count(trials, p, float4(u0, u1, 0.0, 0.0));
}

// The count K of the footprint of g (uv, J) on DB23's grids at p: the footprint's N |det J| facets split over
// the cells it covers at two scale levels, each cell's count drawn at p from the cell's uniforms, whose keys
// take the angular texel of the tangent-frame half vector ht. 0 where the footprint is degenerate. Shared
// with the area-light method shader (area_light_method_body.h defines DB23_COUNT_ONLY and calls it).
float db23_count(GlintInput g, float3 ht, float p) {
  float2 slope = floor(ht.xy / ht.z * DB23_ANGULAR_RES);
  int2 texel = int2(int(clamp(slope.x, -1073741824.0, 1073741824.0)), int(clamp(slope.y, -1073741824.0, 1073741824.0)));

  // The footprint ellipse J {|x| <= 1 / sqrt(pi)}: singular values of J (the minor one from |det J|).
  float dudx = g.J.x, dvdx = g.J.y, dudy = g.J.z, dvdy = g.J.w;
  float pp = dudx * dudx + dudy * dudy, qq = dudx * dvdx + dudy * dvdy, rr = dvdx * dvdx + dvdy * dvdy;
  float mean = 0.5 * (pp + rr), diff = length(float2(0.5 * (pp - rr), qq));
  float s1 = sqrt(mean + diff);
  float det = abs(dudx * dvdy - dudy * dvdx);
  if (!(s1 > 0.0) || !(det > 0.0)) return 0.0;
  float s2 = det / s1;
  // Beyond the grids' largest ratio the twin widens the footprint and marks it clamped (it then gives 0).
  if (!(s2 > 0.0) || s1 / s2 > 1048576.0) return 0.0;
  float k_pi = 1.0 / sqrt(DB23_PI);
  float major = k_pi * s1, minor = k_pi * s2;
  // The major axis in [0, pi), as the twin wraps it (atan2 gives (-pi, pi], halved).
  float angle = 0.5 * GLINTLAB_ATAN2(2.0 * qq, pp - rr);
  if (angle < 0.0) angle += DB23_PI;
  if (angle >= DB23_PI) angle = 0.0;

  // Scale level: A_l = base 4^l <= pi minor^2 < A_(l+1), the upper level's weight z by area (DB23 eq. 10).
  float r = min(major / minor, 1048576.0);
  float a = DB23_PI * minor * minor;
  float base = 1.0 / DB23_DENSITY;
  int lo = int(floor(0.5 * log2(a / base)));
  for (int it = 0; it < 4 && GLINTLAB_LDEXP(base, 2 * lo) > a; ++it) --lo;
  for (int it = 0; it < 4 && GLINTLAB_LDEXP(base, 2 * lo + 2) <= a; ++it) ++lo;
  float area_lo = GLINTLAB_LDEXP(base, 2 * lo), area_hi = GLINTLAB_LDEXP(base, 2 * lo + 2);
  float z = clamp((a - area_lo) / (area_hi - area_lo), 0.0, 0.99999994);
  lo += DB23_LOD_BIAS;
  area_lo = GLINTLAB_LDEXP(base, 2 * lo);
  area_hi = GLINTLAB_LDEXP(base, 2 * lo + 2);

  // Ratio cell [2^k, 2^(k+1)) with the linear weight y; orientation bin j and its weight x.
  int k = clamp(int(floor(log2(r))), 0, DB23_MAX_LEVEL);
  for (int it = 0; it < 4 && k > 0 && GLINTLAB_LDEXP(1.0, k) > r; ++it) --k;
  for (int it = 0; it < 4 && k < DB23_MAX_LEVEL && GLINTLAB_LDEXP(1.0, k + 1) <= r; ++it) ++k;
  float y;
  if (k >= DB23_MAX_LEVEL) {
    k = DB23_MAX_LEVEL - 1;
    y = 1.0;
  } else {
    y = r / GLINTLAB_LDEXP(1.0, k) - 1.0;
  }
  y = clamp(y, 0.0, 1.0);
  int face = max(k, 1);
  float af = angle / GLINTLAB_LDEXP(DB23_STEP1, 1 - face);
  int j = int(floor(af));
  float x = clamp(af - float(j), 0.0, 1.0);
  j = min(j, (8 << (face - 1)) - 1);

  // The cell's plane vertices (ratio level, orientation) and trilinear weights, lower face first.
  int vr[4], vo[4];
  float vw[4];
  int m;
  if (k == 0) {  // the isotropic grid below, two orientations of ratio 2 above
    vr[0] = 0; vo[0] = 0; vw[0] = 1.0 - y;
    vr[1] = 1; vo[1] = j; vw[1] = y * (1.0 - x);
    vr[2] = 1; vo[2] = j + 1; vw[2] = y * x;
    m = 3;
  } else {  // two orientations below, two of the three above (the upper level's step is half)
    vr[0] = k; vo[0] = j; vw[0] = (1.0 - y) * (1.0 - x);
    vr[1] = k; vo[1] = j + 1; vw[1] = (1.0 - y) * x;
    float x2 = 2.0 * x;
    if (x2 < 1.0) {
      vr[2] = k + 1; vo[2] = 2 * j; vw[2] = y * (1.0 - x2);
      vr[3] = k + 1; vo[3] = 2 * j + 1; vw[3] = y * x2;
    } else {
      vr[2] = k + 1; vo[2] = 2 * j + 1; vw[2] = y * (2.0 - x2);
      vr[3] = k + 1; vo[3] = 2 * j + 2; vw[3] = y * (x2 - 1.0);
    }
    m = 4;
  }
  uint2 seed_key = uint2(g.seed ^ DB23_KEY_SALT, 0u);
  float K = 0.0;
  for (int s = 0; s < 2; ++s) {
    for (int q = 0; q < m; ++q) {
      float w = vw[q] * (s == 0 ? 1.0 - z : z);
      K += db23_term(lo + s, vr[q], vo[q], s == 0 ? area_lo : area_hi, w, g.uv, texel, p, seed_key);
    }
  }
  return K;
}

#ifndef DB23_COUNT_ONLY
float glint(GlintInput g) {
  // Half vector in the tangent frame; D(h) / D(n) for DB23's p = min(R D(h) / D(n), 1).
  float3 ht = float3(dot(g.h, g.t), dot(g.h, g.b), dot(g.h, g.n));
  float c = ht.z / length(ht);
  if (!(c > 0.0)) return 0.0;
  float a2 = DB23_ALPHA * DB23_ALPHA;
  float c2 = c * c;
#if DB23_GGX
  float q = (a2 - 1.0) * c2 + 1.0;
  float ratio_dn = a2 * a2 / (q * q);
#else
  float ratio_dn = exp(-((1.0 - c2) / c2) / a2) / (c2 * c2);
#endif
  float p = min(DB23_R * ratio_dn, 1.0);
  float det = abs(g.J.x * g.J.w - g.J.y * g.J.z);
  if (!(det > 0.0)) return 0.0;
  float K = db23_count(g, ht, p);
  float d_normal = 1.0 / (DB23_PI * a2);
  return d_normal / DB23_R * K / (DB23_DENSITY * det);
}
#endif

#endif
