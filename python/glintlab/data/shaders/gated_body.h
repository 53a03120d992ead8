// DB23's gated Gaussian as their published renderer computes it (glintlab's C++ twin: the law
// "gated_shader"; docs/math/laws.md#law-gated-shader). Written for glintlab from the paper and the
// description of the public shader's arithmetic, in its float32 and half-float steps:
//   P1 = 1 - pow(|1 - p|, n); m = max(n, 1) - 1, mu = m p, sd = sqrt(m p (1 - p)) (the public ports
//   write (n - 1) p: for n < 1 their sd is sqrt of a negative, NaN, and J is what the device's clamp
//   makes of NaN; max(n, 1) gives J = 0, what a NaN-dropping clamp gives, on every device:
//   docs/math/laws.md#law-gated-shader);
//   a soft gate of half-width w = 0.1 saturate(10 P1) saturate(10 (1 - P1)) around P1;
//   both randoms stored as 16-bit floats, the Gaussian one already transformed (Giles' erfinv);
//   K = gate (1 + clamp(floor(z sd + mu), 0, n)), which can reach n + 1 (a defect kept on purpose).
// Contract: float count(float n, float p, float4 u), u.x and u.y used (float4 is vec4 in GLSL).
// The body of gated.hlsl and gated.glsl, which include glintlab_prelude.h first.
#ifndef GATED_BODY_H
#define GATED_BODY_H

float gated_half(float x) { return GLINTLAB_HALF_ROUND(x); }

// Giles (2010), "Approximating the erfinv function", single-precision branch pair.
float gated_erfinv(float x) {
    float w = -log((1.0 - x) * (1.0 + x));
    float q;
    if (w < 5.0) {
        w = w - 2.5;
        q = 2.81022636e-08;
        q = 3.43273939e-07 + q * w;
        q = -3.5233877e-06 + q * w;
        q = -4.39150654e-06 + q * w;
        q = 0.00021858087 + q * w;
        q = -0.00125372503 + q * w;
        q = -0.00417768164 + q * w;
        q = 0.246640727 + q * w;
        q = 1.50140941 + q * w;
    } else {
        w = sqrt(w) - 3.0;
        q = -0.000200214257;
        q = 0.000100950558 + q * w;
        q = 0.00134934322 + q * w;
        q = -0.00367342844 + q * w;
        q = 0.00573950773 + q * w;
        q = -0.0076224613 + q * w;
        q = 0.00943887047 + q * w;
        q = 1.00167406 + q * w;
        q = 2.83297682 + q * w;
    }
    return q * x;
}

float count(float n, float p, float4 u) {
    float theta0 = gated_half(u.x);
    float x = clamp(2.0 * u.y - 1.0, -(1.0 - 1e-6), 1.0 - 1e-6);
    float z = gated_half(1.41421356 * gated_erfinv(x));
    float p1 = 1.0 - pow(abs(1.0 - p), n);
    float m = max(n, 1.0) - 1.0;
    float mu = m * p;
    float sd = sqrt(m * p * (1.0 - p));
    float w = 0.1 * saturate(10.0 * p1) * saturate(10.0 * (1.0 - p1));
#ifdef GATED_BUG_REVERSED_GATE
    float gate = theta0 > p1 ? 1.0 : 0.0;  // a deliberate bug for glintlab's tests
#else
    float gate = w > 1e-7 ? saturate((p1 + w - theta0) / (2.0 * w)) : (theta0 < p1 ? 1.0 : 0.0);
#endif
    float g = clamp(floor(z * sd + mu), 0.0, n);
#ifdef GATED_BUG_PLUS_ONE
    return gate * (1.0 + g) + 1.0;  // a deliberate bug for glintlab's tests
#else
    return gate * (1.0 + g);
#endif
}

#endif
