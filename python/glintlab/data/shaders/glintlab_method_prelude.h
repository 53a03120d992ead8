// The names that let one whole-method body (<method>_method_body.h) compile as HLSL and as GLSL, after
// glintlab_prelude.h's (the law bodies'): the vector types by their HLSL names, the method contract's
// header of the language, and the few intrinsics the two spell differently. A method shader's .hlsl and
// .glsl files are thin wrappers: each defines GLINTLAB_HLSL or GLINTLAB_GLSL and includes this file and
// the body, so both languages compute the same operations (docs/math/glint_images.md#glint-db23-shader).
#ifndef GLINTLAB_METHOD_PRELUDE_H
#define GLINTLAB_METHOD_PRELUDE_H

#include "glintlab_prelude.h"

#if defined(GLINTLAB_GLSL)
#include "glintlab_method_glsl.h"
// float2, float3, uint2 and the like come from glintlab_prelude.h; these two only the methods use.
#define int2 ivec2
#define uint4 uvec4
#define GLINTLAB_ATAN2(y, x) atan((y), (x))
#define GLINTLAB_MSB(x) findMSB(x)
// The high and low words of a 32 x 32-bit product (the instruction where the language has one).
#define GLINTLAB_MUL32(a, b, hi, lo) umulExtended((a), (b), hi, lo)
#define GLINTLAB_LDEXP(x, e) ldexp((x), (e))
#else
#include "glintlab_method_hlsl.h"
#define GLINTLAB_ATAN2(y, x) atan2((y), (x))
#define GLINTLAB_MSB(x) int(firstbithigh(x))
#define GLINTLAB_MUL32(a, b, hi, lo) glintlab_mul32((a), (b), hi, lo)
#define GLINTLAB_LDEXP(x, e) glintlab_ldexp((x), (e))
// x 2^e by two exact power-of-two factors built from their bits (glslang's HLSL ldexp passes a float
// exponent, which SPIR-V's Ldexp refuses); the same value as ldexp while x 2^(e/2) stays normal.
float glintlab_pow2(int e) { return asfloat(uint(clamp(e, -126, 127) + 127) << 23u); }
float glintlab_ldexp(float x, int e) {
  int half_e = e / 2;
  return x * glintlab_pow2(half_e) * glintlab_pow2(e - half_e);
}
// 32 x 32 -> 64-bit product from 16-bit halves (HLSL has no such intrinsic): exact, as umulExtended.
void glintlab_mul32(uint a, uint b, out uint hi, out uint lo) {
  uint a0 = a & 0xFFFFu, a1 = a >> 16u, b0 = b & 0xFFFFu, b1 = b >> 16u;
  uint p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
  uint mid = (p00 >> 16u) + (p01 & 0xFFFFu) + (p10 & 0xFFFFu);
  lo = (mid << 16u) | (p00 & 0xFFFFu);
  hi = p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
}
#endif

#endif
