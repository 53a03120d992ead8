// glintlab's shader-sampler contract, GLSL (docs/math/sampling.md#shader-samplers).
// A shader sampler defines two functions on the half vector h:
//   vec4 sample_h(vec2 uv, vec4 J, vec3 wo, vec4 u)
//       one half vector h (unit, in the shading frame: z along the normal) drawn with the four
//       uniforms u in (0, 1), returned as (h.x, h.y, h.z, pdf), the pdf per steradian of h;
//   float pdf_h(vec2 uv, vec4 J, vec3 wo, vec3 h)
//       the same density at a given unit h.
// or, as renderers write them, two functions on the reflected direction l (the file defines one pair;
// glintlab picks the contract from the functions it finds):
//   vec4 sample_l(vec2 uv, vec4 J, vec3 wo, vec4 u)
//       one unit direction l drawn, returned as (l.x, l.y, l.z, pdf), the pdf per steradian of l (an
//       l below the surface, l.z <= 0, is a lost draw);
//   float pdf_l(vec2 uv, vec4 J, vec3 wo, vec3 l)
//       the same density at a given unit l.
// uv is the pixel's texture position, J its footprint (du/dx, dv/dx, du/dy, dv/dy), wo the unit
// outgoing direction (z > 0); a smooth sampler ignores uv and J. glintlab's wrapper kernel (#version
// 450) includes this file before the sampler's code, which therefore has no #version line of its own.
// Same names in glintlab_sampler_hlsl.h.
#ifndef GLINTLAB_SAMPLER_GLSL_H
#define GLINTLAB_SAMPLER_GLSL_H

#define GLINTLAB_SAMPLER 1
#define GLINTLAB_PI 3.14159265358979323846

#endif
