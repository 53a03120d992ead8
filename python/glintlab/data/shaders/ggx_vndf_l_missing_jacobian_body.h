// A deliberately wrong reflected-direction sampler: ggx_vndf_l_body.h's draws of l, with the pdf of
// their half vector h declared as the pdf of l, the 1 / (4 wo.h) of the map h -> l left out (the mistake
// the reflected-direction contract exists to catch). sample_l and pdf_l agree with each other, so only
// the draws against the pdf can reject it: the harness must (tests/python/test_shader_samplers_l.py).
#ifndef GGX_VNDF_L_MISSING_JACOBIAN_BODY_H
#define GGX_VNDF_L_MISSING_JACOBIAN_BODY_H

#define GGX_VNDF_HELPERS_ONLY
#include "ggx_vndf_body.h"

float ggx_vndf_l_missing_jacobian_pdf(float a, float3 wo, float3 l) {
  if (!(l.z > 0.0)) return 0.0;
  return ggx_vndf_pdf(a, wo, normalize(wo + l));  // wrong: the pdf of h, not of l
}

float4 sample_l(float2 uv, float4 J, float3 wo, float4 u) {
  float3 h = ggx_vndf_sample(ALPHA, wo, u.xy).xyz;
  float3 l = 2.0 * dot(wo, h) * h - wo;
  return float4(l, ggx_vndf_l_missing_jacobian_pdf(ALPHA, wo, l));
}

float pdf_l(float2 uv, float4 J, float3 wo, float3 l) {
  return ggx_vndf_l_missing_jacobian_pdf(ALPHA, wo, l);
}

#endif
