// glintlab's constant-time counting law "head_cf" as a drop-in function (C++ twin: the law
// "head_cf" evaluated in float32; derivation in docs/math/laws.md#law-head-cf). An engine pastes
// head_cf() and calls it with its two uniforms (`glintlab shader --emit head_cf --lang hlsl|glsl` prints
// this body with its includes inlined, ready to paste); count() is glintlab's contract around it.
//
// Y ~ Binomial(floor(n), min(p, 1 - p)) is inverted with u0: the head P(Y <= 2) exactly (q^m through
// exp(m log1p(-pt)), then the ratio recurrence), the tail by the continuity-corrected normal quantile
// with a one-term Cornish-Fisher skewness correction, clamped to [3, m]; K = Y, or m - Y for p > 1/2;
// the fractional facet of a non-integer n is a Bernoulli((n - m) p) drawn with u1.

// The body of head_cf.hlsl and head_cf.glsl, which include glintlab_prelude.h first.
#ifndef HEAD_CF_BODY_H
#define HEAD_CF_BODY_H

#include "glintlab_math.h"

// log(1 + x) of -pt in [-1/2, 0] is glintlab_log1p (glintlab_math.h): a series, to float precision in
// relative terms, not log(1 + x) itself, because a GPU's log is accurate near 1 in absolute terms only
// (Vulkan allows 2^-21): a relative error of 1e-5 at x = -0.002 and 218 ulps of q^m on lavapipe.
// The tail's Phi^-1 is glintlab_quantile (Wichura's AS 241 in float).

// The count of reflecting facets among n (real, >= 0) with probability p, from two uniforms in (0, 1).
float head_cf(float n, float p, float u0, float u1) {
    float m = floor(n);
    float pt = p < 0.5 ? p : 1.0 - p;
    float qt = 1.0 - pt;
    float p0 = exp(m * glintlab_log1p(-pt));
    float p1 = m >= 1.0 ? p0 * m * pt / qt : 0.0;
    float p2 = m >= 2.0 ? p1 * (m - 1.0) * pt / (2.0 * qt) : 0.0;
    float f1 = p0 + p1;
    float f2 = p0 + p1 + p2;
    float y;
    if (u0 <= p0) y = 0.0;
    else if (u0 <= f1) y = 1.0;
    else if (u0 <= f2) y = 2.0;
    else {
        float mu = m * pt;
        float sd = sqrt(mu * (1.0 - pt));
        if (sd > 0.0) {
            float g = (1.0 - 2.0 * pt) / sd;
            float z = glintlab_quantile(u0);
            if (g > 0.0 && z < -3.0 / g) z = -3.0 / g;  // stay on the increasing branch
            float cf = g > 0.0 ? z + g * (z * z - 1.0) / 6.0 : z;
            y = ceil(mu + sd * cf - 0.5);
        } else {
            y = mu;
        }
        y = max(y, 3.0);
    }
    y = min(y, m);
    float whole = p <= 0.5 ? y : m - y;
    return whole + (u1 < (n - m) * p ? 1.0 : 0.0);
}

float count(float n, float p, float4 u) { return head_cf(n, p, u.x, u.y); }

#endif
