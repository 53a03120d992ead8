// KK24's continuous gated Gaussian, in HLSL.
// The law's one body is gated_continuous_body.h, which gated_continuous.glsl includes too, so both languages compute
// the same operations. `glintlab shader --emit gated_continuous --lang hlsl` prints this file with its
// includes inlined: one self-contained file to paste into an engine.
#define GLINTLAB_HLSL
#include "glintlab_prelude.h"
#include "gated_continuous_body.h"
