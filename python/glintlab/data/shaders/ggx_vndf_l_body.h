// GGX visible normals returning the reflected direction, as a renderer's sampler does: the example of
// the reflected-direction contract (sample_l, pdf_l; docs/math/sampling.md#reflected-directions). One
// body for both languages, as ggx_vndf_body.h, whose helpers it uses.
//
// The half vector h is drawn from the visible normals (ggx_vndf_sample), and l is wo mirrored about h.
// The map h -> l = 2 (wo.h) h - wo stretches solid angle by 4 (wo.h) (its Jacobian |dl/dh|), so
//   pdf_l(l) = pdf_h(h) / (4 (wo.h)),   h = normalize(wo + l).
// An l below the surface (l.z <= 0) is returned as drawn: the harness counts it as lost, and pdf_l,
// zero there, integrates over the upper hemisphere to 1 minus the mass such draws carry.
// -D ALPHA=a sets the roughness (default 0.3).
#ifndef GGX_VNDF_L_BODY_H
#define GGX_VNDF_L_BODY_H

#define GGX_VNDF_HELPERS_ONLY
#include "ggx_vndf_body.h"

float ggx_vndf_l_pdf(float a, float3 wo, float3 l) {
  if (!(l.z > 0.0)) return 0.0;
  float3 h = normalize(wo + l);
  float cos_oh = dot(wo, h);
  if (!(cos_oh > 0.0)) return 0.0;
  return ggx_vndf_pdf(a, wo, h) / (4.0 * cos_oh);
}

float4 sample_l(float2 uv, float4 J, float3 wo, float4 u) {
  float3 h = ggx_vndf_sample(ALPHA, wo, u.xy).xyz;
  float3 l = 2.0 * dot(wo, h) * h - wo;
  return float4(l, ggx_vndf_l_pdf(ALPHA, wo, l));
}

float pdf_l(float2 uv, float4 J, float3 wo, float3 l) {
  return ggx_vndf_l_pdf(ALPHA, wo, l);
}

#endif
