// glintlab's constant-time counting law "head_cf" as a drop-in GLSL function (twin of head_cf.hlsl) (C++ twin: the law
// "head_cf" evaluated in float32; derivation in docs/math/laws.md#law-head-cf). An engine pastes
// head_cf() and calls it with its two uniforms; count() is glintlab's contract around it.
//
// Y ~ Binomial(floor(n), min(p, 1 - p)) is inverted with u0: the head P(Y <= 2) exactly (q^m through
// exp(m log1p(-pt)), then the ratio recurrence), the tail by the continuity-corrected normal quantile
// with a one-term Cornish-Fisher skewness correction, clamped to [3, m]; K = Y, or m - Y for p > 1/2;
// the fractional facet of a non-integer n is a Bernoulli((n - m) p) drawn with u1.

// log(1 + x) for x in [-1/2, 0] (GLSL has no log1p), to float precision in relative terms. Not
// log(1 + x) itself: a GPU's log is accurate in absolute terms only near 1 (Vulkan allows 2^-21), a
// relative error of 1e-5 at x = -0.002 and 218 ulps of q^m on lavapipe. Instead the odd series
// log(1 + x) = 2 (s + s^3/3 + s^5/5 + ...), s = x / (2 + x), |s| <= 1/3: eight terms leave < 2e-8.
float head_cf_log1p(float x) {
    float s = x / (2.0 + x);
    float s2 = s * s;
    float t = 1.0 / 15.0;
    t = 1.0 / 13.0 + s2 * t;
    t = 1.0 / 11.0 + s2 * t;
    t = 1.0 / 9.0 + s2 * t;
    t = 1.0 / 7.0 + s2 * t;
    t = 1.0 / 5.0 + s2 * t;
    t = 1.0 / 3.0 + s2 * t;
    t = 1.0 + s2 * t;
    return 2.0 * s * t;
}

// Phi^-1(u) for u in (0, 1): Wichura's AS 241 (PPND16), evaluated in float.
float head_cf_poly7(float c0, float c1, float c2, float c3, float c4, float c5, float c6, float c7, float x) {
    return ((((((c7 * x + c6) * x + c5) * x + c4) * x + c3) * x + c2) * x + c1) * x + c0;
}
float head_cf_quantile(float u) {
    float q = u - 0.5;
    if (abs(q) <= 0.425) {
        float r = 0.180625 - q * q;
        return q * head_cf_poly7(3.3871328727963666080e0, 1.3314166789178437745e+2, 1.9715909503065514427e+3,
                                 1.3731693765509461125e+4, 4.5921953931549871457e+4, 6.7265770927008700853e+4,
                                 3.3430575583588128105e+4, 2.5090809287301226727e+3, r)
                 / head_cf_poly7(1.0, 4.2313330701600911252e+1, 6.8718700749205790830e+2,
                                 5.3941960214247511077e+3, 2.1213794301586595867e+4, 3.9307895800092710610e+4,
                                 2.8729085735721942674e+4, 5.2264952788528545610e+3, r);
    }
    float r = sqrt(-log(q < 0.0 ? u : 1.0 - u));
    float x;
    if (r <= 5.0) {
        r = r - 1.6;
        x = head_cf_poly7(1.42343711074968357734e0, 4.63033784615654529590e0, 5.76949722146069140550e0,
                          3.64784832476320460504e0, 1.27045825245236838258e0, 2.41780725177450611770e-1,
                          2.27238449892691845833e-2, 7.74545014278341407640e-4, r)
          / head_cf_poly7(1.0, 2.05319162663775882187e0, 1.67638483018380384940e0,
                          6.89767334985100004550e-1, 1.48103976427480074590e-1, 1.51986665636164571966e-2,
                          5.47593808499534494600e-4, 1.05075007164441684324e-9, r);
    } else {
        r = r - 5.0;
        x = head_cf_poly7(6.65790464350110377720e0, 5.46378491116411436990e0, 1.78482653991729133580e0,
                          2.96560571828504891230e-1, 2.65321895265761230930e-2, 1.24266094738807843860e-3,
                          2.71155556874348757815e-5, 2.01033439929228813265e-7, r)
          / head_cf_poly7(1.0, 5.99832206555887937690e-1, 1.36929880922735805310e-1,
                          1.48753612908506148525e-2, 7.86869131145613259100e-4, 1.84631831751005468180e-5,
                          1.42151175831644588870e-7, 2.04426310338993978564e-15, r);
    }
    return q < 0.0 ? -x : x;
}

// The count of reflecting facets among n (real, >= 0) with probability p, from two uniforms in (0, 1).
float head_cf(float n, float p, float u0, float u1) {
    float m = floor(n);
    float pt = p < 0.5 ? p : 1.0 - p;
    float qt = 1.0 - pt;
    float p0 = exp(m * head_cf_log1p(-pt));
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
            float z = head_cf_quantile(u0);
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

float count(float n, float p, vec4 u) { return head_cf(n, p, u.x, u.y); }
