// An example glint method for extended lights (area_light_method_body.h), in GLSL.
#define GLINTLAB_GLSL
#include "glintlab_method_prelude.h"
#include "area_light_method_body.h"
