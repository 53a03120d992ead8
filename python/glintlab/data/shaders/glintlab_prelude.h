// The few names that let one law body compile as HLSL and as GLSL. A shipped shader's .hlsl and .glsl
// files are thin wrappers: each defines GLINTLAB_HLSL or GLINTLAB_GLSL, includes this prelude, then
// the law's body (<law>_body.h), written in the subset both languages share (float, abs, clamp,
// floor, sqrt, exp, log, pow, the ternary operator) plus these names. Keeping one body is what keeps
// the two languages' arithmetic the same, operation for operation.
#ifndef GLINTLAB_PRELUDE_H
#define GLINTLAB_PRELUDE_H

#if defined(GLINTLAB_GLSL)
#define float2 vec2
#define float3 vec3
#define float4 vec4
#define saturate(x) clamp((x), 0.0, 1.0)
// Round a float to the nearest half float and back (HLSL's f32tof16 / f16tof32).
#define GLINTLAB_HALF_ROUND(x) unpackHalf2x16(packHalf2x16(vec2((x), 0.0))).x
#elif defined(GLINTLAB_HLSL)
#define GLINTLAB_HALF_ROUND(x) f16tof32(f32tof16(x))
#else
#error "define GLINTLAB_HLSL or GLINTLAB_GLSL before including glintlab_prelude.h"
#endif

#endif
