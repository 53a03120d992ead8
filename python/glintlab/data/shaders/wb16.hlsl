// WB16's sparkle shader (Code 2) as a glintlab method shader, in HLSL: image method "wb16"
// (gl.render("wb16", scene); wb16_star and wb16_lookup_noise are its -D variants). Its one body is
// wb16_body.h, which wb16.glsl includes too, so both languages compute the same operations.
#include "glintlab_method_hlsl.h"
#include "wb16_body.h"
