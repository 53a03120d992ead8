// KK25's dual-gated Gaussian, in HLSL.
// The law's one body is dual_gated_body.h, which dual_gated.glsl includes too, so both languages compute
// the same operations. `glintlab shader --emit dual_gated --lang hlsl` prints this file with its
// includes inlined: one self-contained file to paste into an engine.
#define GLINTLAB_HLSL
#include "glintlab_prelude.h"
#include "dual_gated_body.h"
