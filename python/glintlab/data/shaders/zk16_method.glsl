// ZK16 (as DB23 describes it) as a whole method shader, in GLSL. The method's one body is
// zk16_method_body.h, which the .hlsl and .glsl files both include (docs/guide/gpu_cost.md).
#define GLINTLAB_GLSL
#include "glintlab_method_prelude.h"
#include "zk16_method_body.h"
