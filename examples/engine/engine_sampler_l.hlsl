// An engine-style GGX sampler as a renderer's path tracer writes it: it returns the light direction L
// with the pdf of L, the roughness is the artist's (alpha = roughness^2), and the pdf is the one the
// engine divides by. Written for glintlab's guide (docs/guide/engine_code.md) in the shape engine code
// takes, not taken from an engine. glintlab finds sample_l and pdf_l and tests them as they are:
//
//     s = gl.shader_sampler("examples/engine/engine_sampler_l.hlsl", defines={"ROUGHNESS": 0.55})
//     gl.sampler_test(s).passed
//
// The half vector is drawn from the visible normals by the spherical-cap construction (Dupuy & Benyoub
// 2023): in the stretched configuration the visible normals are the cap of directions around the view
// whose z lies in [-V.z, 1], shifted by the view.

#ifndef ROUGHNESS
#define ROUGHNESS 0.5
#endif

static const float kPi = 3.14159265358979;

float Pow2(float x) { return x * x; }

// GGX normal distribution in the engines' a2 form.
float D_GGX(float a2, float NoH) {
  float d = (NoH * a2 - NoH) * NoH + 1.0;
  return a2 / (kPi * d * d);
}

// Smith's G1 for GGX divided by NoV: G1(V) / NoV = 2 / (NoV + sqrt(a2 + (1 - a2) NoV^2)).
float G1_over_NoV(float a2, float NoV) {
  return 2.0 / (NoV + sqrt(a2 + (1.0 - a2) * NoV * NoV));
}

float3 ImportanceSampleVisibleGGX(float2 E, float a, float3 V) {
  float3 Vs = normalize(float3(a * V.xy, V.z));
  float phi = 2.0 * kPi * E.x;
  float z = (1.0 - E.y) * (1.0 + Vs.z) - Vs.z;
  float sinTheta = sqrt(saturate(1.0 - z * z));
  float3 c = float3(sinTheta * cos(phi), sinTheta * sin(phi), z);
  float3 Hs = c + Vs;
  return normalize(float3(a * Hs.xy, Hs.z));
}

// The engine's pdf of L: the visible-normal pdf of H, D G1(V) VoH / NoV, over the reflection's
// Jacobian 4 VoH.
float VisibleGGXPdfL(float a2, float3 V, float3 L) {
  float3 H = normalize(V + L);
  float NoV = V.z;
  float NoH = saturate(H.z);
  float VoH = saturate(dot(V, H));
  float pdf = D_GGX(a2, NoH) * G1_over_NoV(a2, NoV) * VoH;
  pdf /= 4.0 * VoH;
  return L.z > 0.0 ? pdf : 0.0;
}

float4 sample_l(float2 uv, float4 J, float3 wo, float4 u) {
  float a = Pow2(ROUGHNESS);
  float3 H = ImportanceSampleVisibleGGX(u.xy, a, wo);
  float3 L = reflect(-wo, H);
  return float4(L, VisibleGGXPdfL(a * a, wo, L));
}

float pdf_l(float2 uv, float4 J, float3 wo, float3 l) {
  float a = Pow2(ROUGHNESS);
  return VisibleGGXPdfL(a * a, wo, l);
}
