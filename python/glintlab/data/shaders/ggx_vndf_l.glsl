// GGX visible normals returning the reflected direction l (sample_l, pdf_l), in GLSL
// (glintlab_sampler_glsl.h). The one body is ggx_vndf_l_body.h, shared with ggx_vndf_l.hlsl.
// Test it with   glintlab sampler ggx_vndf_l.glsl --param ALPHA=0.3 --param wo=0.6,0,0.8
#define GLINTLAB_GLSL
#include "glintlab_prelude.h"
#include "ggx_vndf_l_body.h"
