// GGX visible normals (Heitz 2018): the shader sampler glintlab ships as the example of the
// shader-sampler contract (docs/math/sampling.md#shader-samplers). One body for both languages:
// ggx_vndf.hlsl and ggx_vndf.glsl define GLINTLAB_HLSL or GLINTLAB_GLSL, include the prelude (which
// maps float2..float4 to GLSL's vec2..vec4) and then this file, written in the subset both share.
// Its numpy twin is gl.sampler("ggx_vndf") (python/glintlab/api/samplers.py): same construction, in
// float64.
//
// -D ALPHA=a sets the roughness (default 0.3). -D GGX_VNDF_HELPERS_ONLY leaves out sample_h and
// pdf_h, so that another file can build its own pair from the helpers (the tests' broken samplers).
#ifndef GGX_VNDF_BODY_H
#define GGX_VNDF_BODY_H

#ifndef ALPHA
#define ALPHA 0.3
#endif

// Isotropic GGX D(h) for a unit h with h.z > 0. The textbook form 1 / (pi a^2 cos^4 (1 + tan^2 / a^2)^2)
// multiplied through by cos^4: 1 / (pi a^2 ((h.x^2 + h.y^2) / a^2 + h.z^2)^2), so no tangent is formed
// and grazing h stays finite.
float ggx_vndf_d(float a, float3 h) {
  float s = (h.x * h.x + h.y * h.y) / (a * a) + h.z * h.z;
  return 1.0 / (GLINTLAB_PI * a * a * s * s);
}

// The visible-normal density of h for the view wo, per steradian of h:
//   G1(wo) max(0, wo.h) D(h) / wo.z,   G1(wo) = 2 wo.z / (wo.z + sqrt(a^2 (wo.x^2 + wo.y^2) + wo.z^2)),
// so wo.z cancels: 2 max(0, wo.h) D(h) / (wo.z + sqrt(a^2 (wo.x^2 + wo.y^2) + wo.z^2)). Zero below the
// surface (h.z <= 0), where D is zero.
float ggx_vndf_pdf(float a, float3 wo, float3 h) {
  if (!(h.z > 0.0)) return 0.0;
  float root = sqrt(a * a * (wo.x * wo.x + wo.y * wo.y) + wo.z * wo.z);
  return 2.0 * max(0.0, dot(wo, h)) * ggx_vndf_d(a, h) / (wo.z + root);
}

// One visible normal from two uniforms. Stretching the view by a in x and y turns the surface into the
// a = 1 one, whose normals are a hemisphere: the normals that view sees are then uniform over the disk
// the hemisphere projects to, perpendicular to the stretched view v. That projection is a half disk
// (the cap facing v) joined to half an ellipse of semi-axis v.z (the rest of the hemisphere's outline,
// seen obliquely). A uniform point of the unit disk is drawn, its coordinate along the tilt is
// squeezed onto that outline (a linear map per column, which keeps the density uniform over the
// projected area), lifted back onto the hemisphere along v, and unstretched.
float4 ggx_vndf_sample(float a, float3 wo, float2 u) {
  float3 v = normalize(float3(a * wo.x, a * wo.y, wo.z));
  // A frame around v: t1 horizontal (any horizontal axis when v is the normal), t2 = v x t1.
  float l2 = v.x * v.x + v.y * v.y;
  float3 t1 = float3(1.0, 0.0, 0.0);
  if (l2 > 0.0) t1 = float3(-v.y, v.x, 0.0) / sqrt(l2);
  float3 t2 = cross(v, t1);
  // A uniform point of the unit disk, in polar form.
  float r = sqrt(u.x);
  float phi = 2.0 * GLINTLAB_PI * u.y;
  float p1 = r * cos(phi);
  float p2 = r * sin(phi);
  // Each column p1 of the disk spans [-w, w], w = sqrt(1 - p1^2); the projected outline spans
  // [-v.z w, w] there. The affine map p2 -> (1 - s) w + s p2 with s = (1 + v.z) / 2 takes one onto the
  // other.
  float s = 0.5 * (1.0 + v.z);
  p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
  // Back onto the hemisphere along v, then unstretched (the normal's x and y scale by a).
  float3 n = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * v;
  float3 h = normalize(float3(a * n.x, a * n.y, max(0.0, n.z)));
  return float4(h, ggx_vndf_pdf(a, wo, h));
}

#ifndef GGX_VNDF_HELPERS_ONLY
float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) {
  return ggx_vndf_sample(ALPHA, wo, u.xy);
}

float pdf_h(float2 uv, float4 J, float3 wo, float3 h) {
  return ggx_vndf_pdf(ALPHA, wo, h);
}
#endif

#endif
