// glintlab's shader-sampler contract, GLSL (docs/math/sampling.md#shader-samplers).
// A shader sampler defines two functions:
//   vec4 sample_h(vec2 uv, vec4 J, vec3 wo, vec4 u)
//       one half vector h (unit, in the shading frame: z along the normal) drawn with the four
//       uniforms u in (0, 1), returned as (h.x, h.y, h.z, pdf), the pdf per steradian of h;
//   float pdf_h(vec2 uv, vec4 J, vec3 wo, vec3 h)
//       the same density at a given unit h.
// uv is the pixel's texture position, J its footprint (du/dx, dv/dx, du/dy, dv/dy), wo the unit
// outgoing direction (z > 0); a smooth sampler ignores uv and J. glintlab's wrapper kernel (#version
// 450) includes this file before the sampler's code, which therefore has no #version line of its own.
// Same names in glintlab_sampler_hlsl.h.
#ifndef GLINTLAB_SAMPLER_GLSL_H
#define GLINTLAB_SAMPLER_GLSL_H

#define GLINTLAB_SAMPLER 1
#define GLINTLAB_PI 3.14159265358979323846

#endif
