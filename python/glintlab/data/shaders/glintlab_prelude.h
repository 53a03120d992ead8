// The few names that let one body compile as HLSL and as GLSL. A shipped shader's .hlsl and .glsl
// files are thin wrappers: each defines GLINTLAB_HLSL or GLINTLAB_GLSL, includes this prelude, then
// the body (<law>_body.h for a law; glintlab_method_body.h and <method>_body.h for a method shader),
// written in the subset both languages share (float, abs, clamp, floor, sqrt, exp, log, pow, dot,
// normalize, length, sign, the ternary operator, structs, integer vectors and their bit operations)
// plus these names: HLSL's, which GLSL gets as macros. Keeping one body is what keeps the two
// languages' arithmetic the same, operation for operation.
#ifndef GLINTLAB_PRELUDE_H
#define GLINTLAB_PRELUDE_H

#if defined(GLINTLAB_GLSL)
#define float2 vec2
#define float3 vec3
#define float4 vec4
#define int3 ivec3
#define uint2 uvec2
#define uint3 uvec3
#define frac(x) fract(x)
#define saturate(x) clamp((x), 0.0, 1.0)
// Round a float to the nearest half float and back (HLSL's f32tof16 / f16tof32).
#define GLINTLAB_HALF_ROUND(x) unpackHalf2x16(packHalf2x16(vec2((x), 0.0))).x
#elif defined(GLINTLAB_HLSL)
#define GLINTLAB_HALF_ROUND(x) f16tof32(f32tof16(x))
#else
#error "define GLINTLAB_HLSL or GLINTLAB_GLSL before including glintlab_prelude.h"
#endif

#endif
