// glintlab's constant-time counting law head_cf, in GLSL.
// The law's one body is head_cf_body.h, which head_cf.hlsl includes too, so both languages compute
// the same operations. `glintlab shader --emit head_cf --lang glsl` prints this file with its
// includes inlined: one self-contained file to paste into an engine.
#define GLINTLAB_GLSL
#include "glintlab_prelude.h"
#include "head_cf_body.h"
