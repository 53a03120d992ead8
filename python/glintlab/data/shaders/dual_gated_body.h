// KK25's dual-gated Gaussian (C++ twin: the law "dual_gated" in float32; docs/math/laws.md#law-dual-gated),
// written for glintlab from the paper: one uniform u.x gates both extremes.
//   n >= 2: K = n if u.x < p^n; K = 0 if u.x >= 1 - (1 - p)^n; else the central Gaussian
//           clamp(1 + (n - 2) p + sqrt((n - 2) p (1 - p)) Phi^-1(u.y), 1, n - 1) (real);
//   n < 2:  the mixture exact at n = 1 and 2: s = clamp(n - 1, 0, 1) on two facets, t = 1 - |1 - n| on
//           one; [0, s p^2) -> 2, then t p -> 1, the top s (1 - p)^2 + t (1 - p) -> 0, the rest -> 1.
// The body of dual_gated.hlsl and dual_gated.glsl, which include glintlab_prelude.h first.
#ifndef DUAL_GATED_BODY_H
#define DUAL_GATED_BODY_H

#include "glintlab_math.h"

float count(float n, float p, float4 u) {
    float all_, one, none, top;
    if (n >= 2.0) {
        all_ = exp(n * log(p));                          // p^n (0 at p = 0: log 0 = -inf)
        one = all_;
        none = -glintlab_expm1(n * glintlab_log1p(-p));  // 1 - (1 - p)^n without cancellation
        top = n;
    } else {
        float s = n > 1.0 ? n - 1.0 : 0.0;
        float t = n > 1.0 ? 2.0 - n : n;
        all_ = s * p * p;
        one = all_ + t * p;
        none = 1.0 - (s * (1.0 - p) * (1.0 - p) + t * (1.0 - p));
        top = 2.0;
    }
    if (u.x < all_) return top;
    if (u.x < one) return 1.0;
    if (!(u.x < none) || n <= 1.0) return 0.0;
    if (n < 2.0) return 1.0;
    float var = (n - 2.0) * p * (1.0 - p);
    float a = 1.0 + (n - 2.0) * p;
    float sd = var > 0.0 ? sqrt(var) : 0.0;
    float x = a + (sd > 0.0 ? sd * glintlab_quantile(u.y) : 0.0);
    float hi = n - 1.0;
    return x < 1.0 ? 1.0 : (x > hi ? hi : x);
}

#endif
