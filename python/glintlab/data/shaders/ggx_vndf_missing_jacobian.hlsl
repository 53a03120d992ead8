// A deliberately wrong sample_h / pdf_h (the pdf of l handed over as the pdf of h), in HLSL
// (glintlab_sampler_hlsl.h). The one body is ggx_vndf_missing_jacobian_body.h, shared with ggx_vndf_missing_jacobian.glsl.
// Test it with   glintlab sampler ggx_vndf_missing_jacobian.hlsl --param ALPHA=0.3 --param wo=0.6,0,0.8
#define GLINTLAB_HLSL
#include "glintlab_prelude.h"
#include "ggx_vndf_missing_jacobian_body.h"
