// Float math shared by glintlab's shipped shaders gated_continuous, dual_gated and head_cf: scalar float code
// that HLSL and GLSL both compile (no language-specific intrinsics), #included next to them. Written
// for what a GPU's transcendentals allow: log and exp are accurate in relative terms away from 1 and
// 0, but log near 1 only in absolute terms (Vulkan: 2^-21), so log1p and expm1 of small arguments
// are computed by series (docs/guide/shaders.md#shaders-agreement).

#ifndef GLINTLAB_MATH_H
#define GLINTLAB_MATH_H

// log(1 + x), x >= -1: the odd series 2 (s + s^3/3 + ...), s = x / (2 + x), for |x| <= 1/2 (|s| <= 1/3,
// eight terms leave < 2e-8 relative); log(1 + x) itself beyond, where |log| >= 0.4 keeps the absolute
// error relatively small.
float glintlab_log1p(float x) {
    if (abs(x) > 0.5) return log(1.0 + x);
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

// exp(y) - 1: Taylor to y^9/9! for |y| <= 1/2 (relative error < 1e-9), exp(y) - 1 beyond.
float glintlab_expm1(float y) {
    if (abs(y) > 0.5) return exp(y) - 1.0;
    float t = 1.0 / 362880.0;
    t = 1.0 / 40320.0 + y * t;
    t = 1.0 / 5040.0 + y * t;
    t = 1.0 / 720.0 + y * t;
    t = 1.0 / 120.0 + y * t;
    t = 1.0 / 24.0 + y * t;
    t = 1.0 / 6.0 + y * t;
    t = 0.5 + y * t;
    t = 1.0 + y * t;
    return y * t;
}

float glintlab_poly7(float c0, float c1, float c2, float c3, float c4, float c5, float c6, float c7, float x) {
    return ((((((c7 * x + c6) * x + c5) * x + c4) * x + c3) * x + c2) * x + c1) * x + c0;
}

// Phi^-1(u) for u in (0, 1): Wichura's AS 241 (PPND16) in float, as glintlab's C++ laws evaluate it.
float glintlab_quantile(float u) {
    float q = u - 0.5;
    if (abs(q) <= 0.425) {
        float r = 0.180625 - q * q;
        return q * glintlab_poly7(3.3871328727963666080e0, 1.3314166789178437745e+2, 1.9715909503065514427e+3,
                                  1.3731693765509461125e+4, 4.5921953931549871457e+4, 6.7265770927008700853e+4,
                                  3.3430575583588128105e+4, 2.5090809287301226727e+3, r)
                 / glintlab_poly7(1.0, 4.2313330701600911252e+1, 6.8718700749205790830e+2,
                                  5.3941960214247511077e+3, 2.1213794301586595867e+4, 3.9307895800092710610e+4,
                                  2.8729085735721942674e+4, 5.2264952788528545610e+3, r);
    }
    float r = sqrt(-log(q < 0.0 ? u : 1.0 - u));
    float x;
    if (r <= 5.0) {
        r = r - 1.6;
        x = glintlab_poly7(1.42343711074968357734e0, 4.63033784615654529590e0, 5.76949722146069140550e0,
                           3.64784832476320460504e0, 1.27045825245236838258e0, 2.41780725177450611770e-1,
                           2.27238449892691845833e-2, 7.74545014278341407640e-4, r)
          / glintlab_poly7(1.0, 2.05319162663775882187e0, 1.67638483018380384940e0,
                           6.89767334985100004550e-1, 1.48103976427480074590e-1, 1.51986665636164571966e-2,
                           5.47593808499534494600e-4, 1.05075007164441684324e-9, r);
    } else {
        r = r - 5.0;
        x = glintlab_poly7(6.65790464350110377720e0, 5.46378491116411436990e0, 1.78482653991729133580e0,
                           2.96560571828504891230e-1, 2.65321895265761230930e-2, 1.24266094738807843860e-3,
                           2.71155556874348757815e-5, 2.01033439929228813265e-7, r)
          / glintlab_poly7(1.0, 5.99832206555887937690e-1, 1.36929880922735805310e-1,
                           1.48753612908506148525e-2, 7.86869131145613259100e-4, 1.84631831751005468180e-5,
                           1.42151175831644588870e-7, 2.04426310338993978564e-15, r);
    }
    return q < 0.0 ? -x : x;
}

#endif
