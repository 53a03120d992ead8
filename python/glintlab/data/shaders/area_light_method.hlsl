// An example glint method for extended lights (area_light_method_body.h), in HLSL.
#define GLINTLAB_HLSL
#include "glintlab_method_prelude.h"
#include "area_light_method_body.h"
