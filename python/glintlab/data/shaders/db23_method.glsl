// DB23's counting pipeline as a whole method shader, in GLSL. The method's one body is
// db23_method_body.h, which the .hlsl and .glsl files both include (docs/math/glint_images.md#glint-db23-shader).
#define GLINTLAB_GLSL
#include "glintlab_method_prelude.h"
#include "db23_method_body.h"
