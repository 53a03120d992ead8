// DB23's gated Gaussian as their published renderer computes it, in HLSL.
// The law's one body is gated_body.h, which gated.glsl includes too, so both languages compute
// the same operations. `glintlab shader --emit gated --lang hlsl` prints this file with its
// includes inlined: one self-contained file to paste into an engine.
#define GLINTLAB_HLSL
#include "glintlab_prelude.h"
#include "gated_body.h"
