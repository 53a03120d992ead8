// KK24's continuous gated Gaussian, in GLSL.
// The law's one body is gated_continuous_body.h, which gated_continuous.hlsl includes too, so both languages compute
// the same operations. `glintlab shader --emit gated_continuous --lang glsl` prints this file with its
// includes inlined: one self-contained file to paste into an engine.
#define GLINTLAB_GLSL
#include "glintlab_prelude.h"
#include "gated_continuous_body.h"
