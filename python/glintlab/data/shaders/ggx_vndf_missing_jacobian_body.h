// A deliberately wrong half-vector sampler: an engine's GGX visible normals whose code keeps the pdf of
// the reflected direction, pdf_h(h) / (4 wo.h), and hands it to the half-vector contract without the
// 4 (wo.h) that turns it back into a pdf of h. sample_h and pdf_h agree with each other, so only the
// draws against the pdf can reject it: the harness must (tests/python/test_shader_samplers_l.py).
#ifndef GGX_VNDF_MISSING_JACOBIAN_BODY_H
#define GGX_VNDF_MISSING_JACOBIAN_BODY_H

#define GGX_VNDF_HELPERS_ONLY
#include "ggx_vndf_body.h"

float ggx_vndf_missing_jacobian_pdf(float a, float3 wo, float3 h) {
  float cos_oh = dot(wo, h);
  if (!(cos_oh > 0.0)) return 0.0;
  return ggx_vndf_pdf(a, wo, h) / (4.0 * cos_oh);  // wrong: the pdf of l, not of h
}

float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) {
  float3 h = ggx_vndf_sample(ALPHA, wo, u.xy).xyz;
  return float4(h, ggx_vndf_missing_jacobian_pdf(ALPHA, wo, h));
}

float pdf_h(float2 uv, float4 J, float3 wo, float3 h) {
  return ggx_vndf_missing_jacobian_pdf(ALPHA, wo, h);
}

#endif
