// KK24's continuous gated Gaussian (C++ twin: the law "gated_continuous" in float32;
// docs/math/laws.md#law-gated-continuous), written for glintlab from the paper:
//   m = max(n, 1); P1 = 1 - (1 - p)^n for n >= 1 (as -expm1(n log1p(-p))), n p below (continuous at 1);
//   G = 1 + (m - 1) p + sqrt((m - 1) p (1 - p)) Phi^-1(u.y), real (no floor);
//   K = [u.x < P1] clamp(G, 1, m)   (a hard gate).
// The body of gated_continuous.hlsl and gated_continuous.glsl, which include glintlab_prelude.h first.
#ifndef GATED_CONTINUOUS_BODY_H
#define GATED_CONTINUOUS_BODY_H

#include "glintlab_math.h"

float count(float n, float p, float4 u) {
    float p1 = n < 1.0 ? n * p : -glintlab_expm1(n * glintlab_log1p(-p));
    if (!(u.x < p1)) return 0.0;
    float m = n > 1.0 ? n : 1.0;
    float var = (m - 1.0) * p * (1.0 - p);
    float a = 1.0 + (m - 1.0) * p;
    float s = var > 0.0 ? sqrt(var) : 0.0;
    float g = a + (s > 0.0 ? s * glintlab_quantile(u.y) : 0.0);
    return g < 1.0 ? 1.0 : (g > m ? m : g);
}

#endif
