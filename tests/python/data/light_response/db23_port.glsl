// A port of DB23's method shader as a user would write one for `glintlab images --method FILE
// --method-returns ndf`: glintlab's DB23 body under the material glintlab passes (GLINTLAB_*). The
// light-response tests' correct port, beside its two deliberately wrong ones (hx_bug.glsl, wide_lobe.glsl).
#define GLINTLAB_GLSL
#include "glintlab_method_prelude.h"
#define DB23_DENSITY GLINTLAB_DENSITY
#define DB23_ALPHA GLINTLAB_ALPHA
#define DB23_R GLINTLAB_R
#define DB23_GGX GLINTLAB_GGX
#include "db23_method_body.h"
