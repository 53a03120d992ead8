// KPT25's Algorithm 1 as a whole method shader, in HLSL. The method's one body is
// kpt25_method_body.h, which the .hlsl and .glsl files both include (docs/math/glint_images.md#glint-kpt25-shader).
#define GLINTLAB_HLSL
#include "glintlab_method_prelude.h"
#include "kpt25_method_body.h"
