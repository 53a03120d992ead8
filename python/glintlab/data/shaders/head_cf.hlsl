// glintlab's constant-time counting law head_cf, in HLSL.
// The law's one body is head_cf_body.h, which head_cf.glsl includes too, so both languages compute
// the same operations. `glintlab shader --emit head_cf --lang hlsl` prints this file with its
// includes inlined: one self-contained file to paste into an engine.
#define GLINTLAB_HLSL
#include "glintlab_prelude.h"
#include "head_cf_body.h"
