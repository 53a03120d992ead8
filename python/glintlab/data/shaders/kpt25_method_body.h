// KPT25's Algorithm 1 as a whole method shader (docs/math/glint_images.md#glint-kpt25-shader): per pixel,
// from GlintInput's uv, J, shading frame and h, the glinty NDF value
//     D^f = D(h) (sum over the points of B(k) at two MIP levels / K_P + compensation)     (eq. 11)
// over the same point process as glintlab's C++ KPT25 (its twin): one point per 4D cell (spatial cell
// (i, j) of side 2^l / sqrt(K_P), angular cell (a, b) of side 2^-l in the unit square), its four
// coordinates from the Philox4x32-10 block keyed by the seed with the counter (2a + block, i, j,
// 8 << 24 | l << 20 | b), points outside the disk U rejected, a truncated Gaussian pixel filter
// (Mahalanobis radius 3, renormalised), the k = 4 angular cells nearest T(h), the smoothstep roulette
// between the two levels (eps), and eq. 10's square compensation. The map T is the orthographic one
// (Beckmann: Marsaglia's polar map of the slopes; GGX: the stretched normal's projection).
// The method returns D, not an intensity: glintlab shades it with the microfacet BRDF.
//
// Defines: KPT25_DENSITY K_P (points per unit uv area), KPT25_RES (its square root, computed in double
// by glintlab), KPT25_ALPHA, KPT25_GGX, KPT25_ALPHA_STAR, KPT25_EPSILON, KPT25_FILTER (pixel filter std
// in pixels). For the tests' deliberately wrong variants: KPT25_LOD_BIAS (added to the MIP level) and
// KPT25_KEY_SALT (xored into the Philox key).
#ifndef KPT25_METHOD_BODY_H
#define KPT25_METHOD_BODY_H

#include "glintlab_rng.h"

#ifndef KPT25_DENSITY
#define KPT25_DENSITY 1310720000.0
#endif
#ifndef KPT25_RES
#define KPT25_RES 36203.9
#endif
#ifndef KPT25_ALPHA
#define KPT25_ALPHA 1.0
#endif
#ifndef KPT25_GGX
#define KPT25_GGX 0
#endif
#ifndef KPT25_ALPHA_STAR
#define KPT25_ALPHA_STAR 0.02
#endif
#ifndef KPT25_EPSILON
#define KPT25_EPSILON 0.1
#endif
#ifndef KPT25_FILTER
#define KPT25_FILTER 0.28209479177387814
#endif
#ifndef KPT25_LOD_BIAS
#define KPT25_LOD_BIAS 0.0
#endif
#ifndef KPT25_KEY_SALT
#define KPT25_KEY_SALT 0u
#endif

#define KPT25_PI 3.14159265358979
#define KPT25_FILTER_MASS 0.988891003461758  // 1 - exp(-9/2): the truncated 2D Gaussian's mass
#define KPT25_MAX_LEVEL 15

// erfc(x) in float32: the Chebyshev fit t exp(-x^2 + P(t)), t = 1 / (1 + |x| / 2), of Numerical
// Recipes (relative error below 1.2e-7 everywhere), reflected for x < 0.
float kpt25_erfc(float x) {
  float z = abs(x);
  float t = 1.0 / (1.0 + 0.5 * z);
  float p = -0.82215223 + t * 0.17087277;
  p = 1.48851587 + t * p;
  p = -1.13520398 + t * p;
  p = 0.27886807 + t * p;
  p = -0.18628806 + t * p;
  p = 0.09678418 + t * p;
  p = 0.37409196 + t * p;
  p = 1.00002368 + t * p;
  p = -1.26551223 + t * p;
  float r = t * exp(-z * z + p);
  return x >= 0.0 ? r : 2.0 - r;
}

// Phi(b) - Phi(a), a <= b, without cancellation in either tail (the twin's branches).
float kpt25_normal_mass(float a, float b) {
  if (!(b > a)) return 0.0;
  if (a > 40.0 || b < -40.0) return 0.0;
  if (a < -8.5 && b > 8.5) return 1.0;
  float s = 0.70710678118654752;
  // The twin's three branches with their erfc arguments selected, so that the device compiles two erfc
  // calls, not six (the compensation takes six masses per level).
  bool upper = a >= 0.0, lower = b <= 0.0;
  float ex = kpt25_erfc((upper ? a : (lower ? -b : -a)) * s), ey = kpt25_erfc((upper ? b : (lower ? -a : b)) * s);
  return upper || lower ? 0.5 * (ex - ey) : 1.0 - 0.5 * (ex + ey);
}
float kpt25_mass_1d(float c, float sigma, float lo, float hi) {
  return kpt25_normal_mass((lo - c) / sigma, (hi - c) / sigma);
}

// The first of the 2 angular cells of B(k) on one axis: the pair whose centres are nearest q (cells).
int kpt25_block_first(float q, int n) {
  if (n <= 2) return 0;
  return clamp(int(floor(q - 0.5)), 0, n - 2);
}

float kpt25_roulette(float r, float w) {
  float lo = max(0.0, r - KPT25_EPSILON), hi = min(1.0, r + KPT25_EPSILON);
  if (!(hi > lo)) return w >= r ? 1.0 : 0.0;
  float t = clamp((w - lo) / (hi - lo), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

uint4 kpt25_block(uint2 key, int level, int i, int j, int a, int b, uint block) {
  uint4 c = uint4(uint(2 * a) + block, uint(i), uint(j), (8u << 24u) | (uint(level) << 20u) | uint(b));
  return glintlab_philox(c, key);
}

struct Kpt25Pixel {
  float xa, ya, sigma, inv_a, inv_b, inv_c, norm, half_u, half_v;
};

// One level's explicit sum over B(k) (Algorithm 1, lines 13-18), divided by the lobes' 2 pi sigma^2.
float kpt25_level_sum(Kpt25Pixel px, int level, float weight, float2 uv, uint2 key) {
  float cell = GLINTLAB_LDEXP(1.0, level) / KPT25_RES;
  int na = 1 << level;
  float fna = float(na);
  int i0 = int(floor((uv.x - px.half_u) / cell)), i1 = int(floor((uv.x + px.half_u) / cell));
  int j0 = int(floor((uv.y - px.half_v) / cell)), j1 = int(floor((uv.y + px.half_v) / cell));
  i1 = min(i1, i0 + 7);  // the level keeps the box within 3 cells; a guard, never reached in practice
  j1 = min(j1, j0 + 7);
  int a0 = kpt25_block_first(px.xa * fna, na), a1 = min(a0 + 1, na - 1);
  int b0 = kpt25_block_first(px.ya * fna, na), b1 = min(b0 + 1, na - 1);
  float inv_na = 1.0 / fna;
  float inv2s2 = 0.5 / (px.sigma * px.sigma);
  bool roulette = weight < 1.0;
  float sum = 0.0;
  for (int i = i0; i <= i1; ++i)
    for (int j = j0; j <= j1; ++j)
      for (int a = a0; a <= a1; ++a)
        for (int b = b0; b <= b1; ++b) {
          uint4 r4 = kpt25_block(key, level, i, j, a, b, 0u);
          float mx = (float(a) + glintlab_unit32(r4.z)) * inv_na;
          float my = (float(b) + glintlab_unit32(r4.w)) * inv_na;
          if ((mx - 0.5) * (mx - 0.5) + (my - 0.5) * (my - 0.5) >= 0.25) continue;
          float dx = (float(i) + glintlab_unit32(r4.x)) * cell - uv.x;
          float dy = (float(j) + glintlab_unit32(r4.y)) * cell - uv.y;
          float q = px.inv_a * dx * dx + 2.0 * px.inv_b * dx * dy + px.inv_c * dy * dy;
          if (q > 9.0) continue;
          float keep = weight;
          if (roulette) keep = kpt25_roulette(glintlab_unit32(kpt25_block(key, level, i, j, a, b, 1u).x), weight);
          if (keep == 0.0) continue;
          float ex = mx - px.xa, ey = my - px.ya;
          sum += keep * px.norm * exp(-0.5 * q - (ex * ex + ey * ey) * inv2s2);
        }
  return sum / (2.0 * KPT25_PI * px.sigma * px.sigma);
}

// Eq. 10: the lobe's mass in the unit square minus its mass in B(k) (products of 1D normal masses),
// written as sq_x out_y + in_y out_x, out = the 1D mass of [0, 1] outside B(k)'s interval (none past an
// end that is the square's edge, decided on the cell index), so that it is >= 0 by construction. The
// twin's difference of the two products cancels in float32 when the lobe lies in B(k) within a few
// stds of the square's edge, and the device rounds that edge (1, and the block's end) differently in
// the two masses (by up to 1e-3 lobe stds on lavapipe): D came out negative, down to -0.04 D(h)
// (docs/math/glint_images.md#glint-kpt25-shader).
float kpt25_compensation(Kpt25Pixel px, int level) {
  int na = 1 << level;
  float fna = float(na);
  int a0 = kpt25_block_first(px.xa * fna, na), a1 = na <= 2 ? na - 1 : a0 + 1;
  int b0 = kpt25_block_first(px.ya * fna, na), b1 = na <= 2 ? na - 1 : b0 + 1;
  float s = px.sigma;
  float ax = GLINTLAB_LDEXP(float(a0), -level), bx = GLINTLAB_LDEXP(float(a1 + 1), -level);
  float ay = GLINTLAB_LDEXP(float(b0), -level), by = GLINTLAB_LDEXP(float(b1 + 1), -level);
  float out_x = (a0 > 0 ? kpt25_mass_1d(px.xa, s, 0.0, ax) : 0.0) + (a1 + 1 < na ? kpt25_mass_1d(px.xa, s, bx, 1.0) : 0.0);
  float out_y = (b0 > 0 ? kpt25_mass_1d(px.ya, s, 0.0, ay) : 0.0) + (b1 + 1 < na ? kpt25_mass_1d(px.ya, s, by, 1.0) : 0.0);
  return kpt25_mass_1d(px.xa, s, 0.0, 1.0) * out_y + kpt25_mass_1d(px.ya, s, ay, by) * out_x;
}

float glint(GlintInput g) {
  // T(h) and D(h) (the twin's map): h in the shading frame, normalised.
  float3 h = float3(dot(g.h, g.t), dot(g.h, g.b), dot(g.h, g.n));
  h = h / length(h);
  if (!(h.z > 0.0)) return 0.0;
  float a2 = KPT25_ALPHA * KPT25_ALPHA;
  float dx, dy, D;
#if KPT25_GGX
  float sx = h.x / KPT25_ALPHA, sy = h.y / KPT25_ALPHA;
  float nn = sqrt(sx * sx + sy * sy + h.z * h.z);
  dx = sx / nn;
  dy = sy / nn;
  float qg = (a2 - 1.0) * h.z * h.z + 1.0;
  D = a2 / (KPT25_PI * qg * qg);
#else
  float r2 = h.x * h.x + h.y * h.y;
  float s2 = r2 / (h.z * h.z), t = s2 / a2;
  if (!(t < 80.0)) return 0.0;  // D underflows float32 (the twin's value is below 1e-34)
  // 1 - exp(-t) without cancellation for small t (its series to t^4: relative error below 1e-9 there).
  float one_minus = t < 0.03 ? t * (1.0 - t * (0.5 - t * (1.0 / 6.0 - t / 24.0))) : 1.0 - exp(-t);
  float scale = t > 1e-30 ? sqrt(one_minus / t) / KPT25_ALPHA : 1.0 / KPT25_ALPHA;
  dx = h.x / h.z * scale;
  dy = h.y / h.z * scale;
  D = exp(-t + 2.0 * log(1.0 + s2)) / (KPT25_PI * a2);
#endif
  Kpt25Pixel px;
  px.xa = 0.5 + 0.5 * dx;
  px.ya = 0.5 + 0.5 * dy;
  px.sigma = KPT25_ALPHA_STAR * sqrt(D);
  if (!(px.sigma * px.sigma > 1e-37)) return 0.0;

  // The pixel filter: covariance f^2 J J^T (Algorithm 1, line 11), its inverse and 3-sigma box.
  float f2 = KPT25_FILTER * KPT25_FILTER;
  float4 J = g.J;
  float suu = f2 * (J.x * J.x + J.z * J.z), svv = f2 * (J.y * J.y + J.w * J.w);
  float suv = f2 * (J.x * J.y + J.z * J.w);
  float detj = J.x * J.w - J.y * J.z;
  float det = f2 * f2 * detj * detj;
  if (!(det > 0.0) || !(det > 1e-24 * suu * svv)) return 0.0;
  px.inv_a = svv / det;
  px.inv_b = -suv / det;
  px.inv_c = suu / det;
  px.norm = 1.0 / (2.0 * KPT25_PI * sqrt(det) * KPT25_FILTER_MASS);
  px.half_u = 3.0 * sqrt(suu);
  px.half_v = 3.0 * sqrt(svv);
  // The MIP level where the filter's box (2 x 3 sigma_major) is one cell; two levels, weights 1 - |lambda - l|.
  float tr = suu + svv, disc = sqrt(max(0.0, 0.25 * (suu - svv) * (suu - svv) + suv * suv));
  float major = sqrt(0.5 * tr + disc);
  float lambda = log2(KPT25_RES * 6.0 * major) + KPT25_LOD_BIAS;
  if (!(lambda <= float(KPT25_MAX_LEVEL))) return 0.0;  // the twin refuses such a pixel (masked out)
  lambda = max(0.0, lambda);
  int l0 = int(floor(lambda));
  float frac = lambda - float(l0);
  uint2 key = uint2(g.seed ^ KPT25_KEY_SALT, 0u);
  float w0 = (frac > 0.0 && l0 < KPT25_MAX_LEVEL) ? 1.0 - frac : 1.0;
  float explicit_sum = kpt25_level_sum(px, l0, w0, g.uv, key);
  float comp = w0 * kpt25_compensation(px, l0);
  if (frac > 0.0 && l0 < KPT25_MAX_LEVEL) {
    explicit_sum += kpt25_level_sum(px, l0 + 1, frac, g.uv, key);
    comp += frac * kpt25_compensation(px, l0 + 1);
  }
  return D * (explicit_sum / KPT25_DENSITY + comp);
}

#endif
