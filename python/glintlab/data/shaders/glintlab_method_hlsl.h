// glintlab's method-shader contract in HLSL (docs/math/glint_images.md#glint-contract): GlintInput, the
// hash and the hashed value noise. Their one body is glintlab_method_body.h, which
// glintlab_method_glsl.h includes too, so both languages declare the same fields and compute
// the same noise. glintlab's wrapper kernel includes this file before the method's code; a method's
// own file may include it again.
#ifndef GLINTLAB_HLSL
#define GLINTLAB_HLSL
#endif
#include "glintlab_prelude.h"
#include "glintlab_method_body.h"
