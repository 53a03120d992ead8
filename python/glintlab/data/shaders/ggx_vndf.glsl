// GGX visible-normal sampler (Heitz 2018) as a glintlab shader sampler, in GLSL: sample_h and pdf_h
// (glintlab_sampler_glsl.h). The one body is ggx_vndf_body.h, shared with ggx_vndf.hlsl.
// Test it with   glintlab sampler ggx_vndf.glsl --param ALPHA=0.3 --param wo=0.6,0,0.8
#define GLINTLAB_GLSL
#include "glintlab_prelude.h"
#include "ggx_vndf_body.h"
