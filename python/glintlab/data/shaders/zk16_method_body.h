// ZK16 (Zirr & Kaplanyan 2016) as DB23 describes it, as a whole method shader
// (docs/guide/gpu_cost.md#the-method-shaders-of-the-two-tables): per pixel, from GlintInput's uv, J, shading
// frame and h, the glinty NDF value
//     D_P = (D(n) / R) K / (N P),   P = |det J|                                     (DB23 eq. 3-4)
// with K counted by ZK16's manual anisotropic filtering (DB23 §3, §7.1, Fig. 11): n_s = min(ceil r, 16)
// isotropic probes evenly spaced along the footprint's major axis (beyond the maximum anisotropy 16 the
// minor axis is widened to major / 16), each of area pi major minor / n_s, counted on the two isotropic
// mip levels around that area (4^l cells of 1 / N) and their outputs blended linearly by the level's log
// weight (ZK16's blend, DB23 eq. 7). The count per cell is ZK16's hybrid (DB23 eq. 15): a Gaussian when
// n p > 5, else a loop of min(n, 16) Bernoulli trials, so the cost of a pixel varies with its anisotropy
// and its n p. With ZK16_GATED = 1 the count is DB23's gated Gaussian instead (gated_body.h), as KPT25's
// Table 3 footnote describes its "Zirr & Kaplanyan*".
//
// Its C++ twin is glintlab's DB23 glinty NDF with scheme "zk16_aniso" and inner law "zk16" (ZK16_GATED:
// "gated_shader"). The shader reads the SAME random numbers: each cell's uniforms from the core's
// splitmix64 keys (glintlab_rng.h), uniform d of a cell mix64(h + d 0x8CB92BA72F3D8DD7). Everything else is
// float32 where the twin computes in double (the footprint, the probe offsets, the Gaussian's quantile by
// Giles' erfinv), so a count can flip at a floor or a cell edge: the documented float32 effects.
//
// Defines: ZK16_DENSITY N, ZK16_ALPHA, ZK16_R, ZK16_GGX, ZK16_ANGULAR_RES (the material, as DB23's shader),
// ZK16_GATED (0 or 1), ZK16_MAX_ANISO (16) and ZK16_CAP (16 Bernoulli trials).
#ifndef ZK16_METHOD_BODY_H
#define ZK16_METHOD_BODY_H

#include "gated_body.h"
#include "glintlab_rng.h"

#ifndef ZK16_DENSITY
#define ZK16_DENSITY 4194304.0
#endif
#ifndef ZK16_ALPHA
#define ZK16_ALPHA 1.0
#endif
#ifndef ZK16_R
#define ZK16_R 0.5
#endif
#ifndef ZK16_GGX
#define ZK16_GGX 0
#endif
#ifndef ZK16_ANGULAR_RES
#define ZK16_ANGULAR_RES 20.0
#endif
#ifndef ZK16_GATED
#define ZK16_GATED 0
#endif
#ifndef ZK16_MAX_ANISO
#define ZK16_MAX_ANISO 16
#endif
#ifndef ZK16_CAP
#define ZK16_CAP 16
#endif

#define ZK16_PI 3.14159265358979

// Uniform d of a cell whose first hash is h (the core's CellUniforms: d = 0 is h itself).
float zk16_uniform(uint2 h, int d) {
  if (d == 0) return glintlab_unit53(h);
  uint2 step = glintlab_u64_mul(uint2(0x2F3D8DD7u, 0x8CB92BA7u), uint2(uint(d), 0u));
  return glintlab_unit53(glintlab_mix64(glintlab_u64_add(h, step)));
}

// ZK16's hybrid (the law "zk16", DB23 eq. 15): Gaussian above n p = 5, else min(floor n, cap) Bernoulli
// trials plus the stratified rule's fractional facet when the cap did not cut the loop.
float zk16_count(float n, float p, uint2 h) {
  if (n * p > 5.0) {
    float mean = n * p;
    float sd = sqrt(mean * (1.0 - p));
    float x = clamp(2.0 * zk16_uniform(h, 0) - 1.0, -(1.0 - 1e-7), 1.0 - 1e-7);
    float g = sd > 0.0 ? mean + sd * 1.41421356 * gated_erfinv(x) : mean;
    return clamp(floor(g), 0.0, ceil(n));
  }
  float whole = floor(n);
  int trials = whole < float(ZK16_CAP) ? int(whole) : ZK16_CAP;
  float k = 0.0;
  for (int i = 0; i < trials; ++i) k += zk16_uniform(h, i) < p ? 1.0 : 0.0;
  if (trials < ZK16_CAP && n > whole) k += zk16_uniform(h, trials) < (n - whole) * p ? 1.0 : 0.0;
  return k;
}

// One probe's count on the isotropic level `level` (cells of side sqrt(area)) at uv point (x, y).
float zk16_cell(int level, float area, float2 xy, int2 texel, float p, uint2 seed_key) {
  float side = sqrt(area);
  // The twin's term has angle 0: X across (v), Y along (u).
  int2 cell = int2(int(clamp(floor(xy.y / side), -2147483520.0, 2147483520.0)),
                   int(clamp(floor(xy.x / side), -2147483520.0, 2147483520.0)));
  uint2 key = glintlab_hash_combine(seed_key, glintlab_u64_from_int(level));
  key = glintlab_hash_combine(key, glintlab_u64_from_int(0));
  key = glintlab_hash_combine(key, glintlab_u64_from_int(0));
  uint2 ta = glintlab_u64_mul(glintlab_u64_from_int(texel.x), uint2(0xA0B428DBu, 0xE7037ED1u));
  uint2 tb = glintlab_u64_mul(glintlab_u64_from_int(texel.y), uint2(0x9C88C6E3u, 0x8EBC6AF0u));
  key = glintlab_mix64(glintlab_u64_add(glintlab_u64_add(key, ta), tb));
  uint2 ca = glintlab_u64_mul(glintlab_u64_from_int(cell.x), uint2(0xD192ED03u, 0xD1B54A32u));
  uint2 cb = glintlab_u64_mul(glintlab_u64_from_int(cell.y), uint2(0xFB8FAC03u, 0xABC98388u));
  uint2 h = glintlab_mix64(glintlab_u64_add(glintlab_u64_add(key, ca), cb));
  float trials = ZK16_DENSITY * area;
#if ZK16_GATED
  return count(trials, p, float4(glintlab_unit53(h), zk16_uniform(h, 1), 0.0, 0.0));
#else
  return zk16_count(trials, p, h);
#endif
}

float glint(GlintInput g) {
  float3 ht = float3(dot(g.h, g.t), dot(g.h, g.b), dot(g.h, g.n));
  float c = ht.z / length(ht);
  if (!(c > 0.0)) return 0.0;
  float a2 = ZK16_ALPHA * ZK16_ALPHA;
  float c2 = c * c;
#if ZK16_GGX
  float q = (a2 - 1.0) * c2 + 1.0;
  float ratio_dn = a2 * a2 / (q * q);
#else
  float ratio_dn = exp(-((1.0 - c2) / c2) / a2) / (c2 * c2);
#endif
  float p = min(ZK16_R * ratio_dn, 1.0);
  float2 slope = floor(ht.xy / ht.z * ZK16_ANGULAR_RES);
  int2 texel = int2(int(clamp(slope.x, -1073741824.0, 1073741824.0)), int(clamp(slope.y, -1073741824.0, 1073741824.0)));

  // The footprint ellipse J {|x| <= 1 / sqrt(pi)}: its axes and the major axis's angle in [0, pi).
  float dudx = g.J.x, dvdx = g.J.y, dudy = g.J.z, dvdy = g.J.w;
  float pp = dudx * dudx + dudy * dudy, qq = dudx * dvdx + dudy * dvdy, rr = dvdx * dvdx + dvdy * dvdy;
  float mean = 0.5 * (pp + rr), diff = length(float2(0.5 * (pp - rr), qq));
  float s1 = sqrt(mean + diff);
  float det = abs(dudx * dvdy - dudy * dvdx);
  if (!(s1 > 0.0) || !(det > 0.0)) return 0.0;
  float s2 = det / s1;
  if (!(s2 > 0.0)) return 0.0;
  float k_pi = 1.0 / sqrt(ZK16_PI);
  float major = k_pi * s1, minor = k_pi * s2;
  float angle = 0.5 * GLINTLAB_ATAN2(2.0 * qq, pp - rr);
  if (angle < 0.0) angle += ZK16_PI;
  if (angle >= ZK16_PI) angle = 0.0;

  // Beyond the maximum anisotropy the minor axis is widened (the glints grow, DB23 Fig. 11).
  if (major / minor > float(ZK16_MAX_ANISO)) minor = major / float(ZK16_MAX_ANISO);
  int probes = clamp(int(ceil(major / minor)), 1, ZK16_MAX_ANISO);
  float area = ZK16_PI * major * minor / float(probes);
  // Isotropic levels: base 4^l <= area < base 4^(l+1), the upper level's weight log4(area / A_l).
  float base = 1.0 / ZK16_DENSITY;
  int lo = int(floor(0.5 * log2(area / base)));
  if (GLINTLAB_LDEXP(base, 2 * lo) > area) --lo;
  if (GLINTLAB_LDEXP(base, 2 * lo + 2) <= area) ++lo;
  float area_lo = GLINTLAB_LDEXP(base, 2 * lo), area_hi = GLINTLAB_LDEXP(base, 2 * lo + 2);
  float w = clamp(0.5 * log2(area / area_lo), 0.0, 0.99999994);
  float scale_lo = area * (1.0 - w) / area_lo, scale_hi = area * w / area_hi;

  float ca = cos(angle), sa = sin(angle);
  // The quarter turn (a footprint along v): the twin's double angle is pi/2 rounded, whose cosine is
  // 6.1e-17, not float32's -4.4e-8; the shader takes the twin's value, so that probes on the column u = 0
  // (a scene's axis) read the twin's cells, not their neighbours across it (as DB23's shader does).
  if (angle == float(0.5 * ZK16_PI)) {
    ca = 6.123234e-17;
    sa = 1.0;
  }
  uint2 seed_key = uint2(g.seed, 0u);
  float K = 0.0;
  for (int s = 0; s < probes; ++s) {
    float offset = ((float(s) + 0.5) / float(probes) - 0.5) * 2.0 * major;
    float2 xy = g.uv + float2(offset * ca, offset * sa);
    K += scale_lo * zk16_cell(lo, area_lo, xy, texel, p, seed_key);
    K += scale_hi * zk16_cell(lo + 1, area_hi, xy, texel, p, seed_key);
  }
  float d_normal = 1.0 / (ZK16_PI * a2);
  return d_normal / ZK16_R * K / (ZK16_DENSITY * det);
}

#endif
