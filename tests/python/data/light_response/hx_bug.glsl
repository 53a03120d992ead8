// Deliberately wrong (tests/python/test_light_response.py): the half vector reaches DB23's glint
// function as one float, as in a public engine port, so the NDF reads (h.x, h.x, h.x) in the shading
// frame. Its flicker along a camera path is close to the correct port's; moving the light is not.
#define GLINTLAB_GLSL
#include "glintlab_method_prelude.h"
#define DB23_DENSITY GLINTLAB_DENSITY
#define DB23_ALPHA GLINTLAB_ALPHA
#define DB23_R GLINTLAB_R
#define DB23_GGX GLINTLAB_GGX
#define glint db23_glint
#include "db23_method_body.h"
#undef glint


float glint(GlintInput g) {
  // The port's glint function takes the tangent-frame half vector as one float: float3(h.x) reaches the
  // NDF. Passed here in an identity frame, so that DB23's body reads exactly (h.x, h.x, h.x).
  GlintInput one_float = g;
  one_float.h = float3(dot(g.h, g.t));
  one_float.t = float3(1.0, 0.0, 0.0);
  one_float.b = float3(0.0, 1.0, 0.0);
  one_float.n = float3(0.0, 0.0, 1.0);
  return db23_glint(one_float);
}
