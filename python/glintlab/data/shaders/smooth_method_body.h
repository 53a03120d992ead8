// The "No Glints" column of DB23's Table 1 as a whole method shader (docs/guide/gpu_cost.md#the-method-shaders-of-the-two-tables):
// the smooth NDF D(h) (Beckmann, or GGX with SMOOTH_GGX = 1) of roughness SMOOTH_ALPHA at the pixel's
// half vector in its shading frame, 0 below the horizon. The baseline every glint method is compared with;
// its twin is the smooth NDF glintlab's glinty NDFs converge to (GlintyNDF.smooth).
#ifndef SMOOTH_METHOD_BODY_H
#define SMOOTH_METHOD_BODY_H

#ifndef SMOOTH_ALPHA
#define SMOOTH_ALPHA 1.0
#endif
#ifndef SMOOTH_GGX
#define SMOOTH_GGX 0
#endif

float glint(GlintInput g) {
  float3 ht = float3(dot(g.h, g.t), dot(g.h, g.b), dot(g.h, g.n));
  float c = ht.z / length(ht);
  if (!(c > 0.0)) return 0.0;
  float a2 = SMOOTH_ALPHA * SMOOTH_ALPHA;
  float c2 = c * c;
#if SMOOTH_GGX
  float q = (a2 - 1.0) * c2 + 1.0;
  return a2 / (3.14159265358979 * q * q);
#else
  return exp(-((1.0 - c2) / c2) / a2) / (3.14159265358979 * a2 * c2 * c2);
#endif
}

#endif
