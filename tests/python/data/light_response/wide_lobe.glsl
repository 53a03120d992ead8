// Deliberately wrong (tests/python/test_light_response.py): DB23's method shader with its roughness
// 1.3 times the material's, a lobe of the wrong width.
#define GLINTLAB_GLSL
#include "glintlab_method_prelude.h"
#define DB23_DENSITY GLINTLAB_DENSITY
#define DB23_ALPHA (1.3 * GLINTLAB_ALPHA)
#define DB23_R GLINTLAB_R
#define DB23_GGX GLINTLAB_GGX
#include "db23_method_body.h"
