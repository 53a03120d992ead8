// glintlab's fragment-shader mode (docs/guide/shaders.md#shaders-fragment): what a GLSL fragment
// shader's glint code finds when it runs in glintlab's compute kernel, four invocations per pixel (a
// quad: the pixel, one right, one down, both). dFdx, dFdy, fwidth (and their Fine / Coarse forms) are the
// differences across the quad, as a GPU computes them between neighbouring pixels; texture() and
// texture2D() read the mip level those derivatives of the coordinate select (textureGrad); gl_FragCoord
// is the lane's pixel centre. The wrapper includes this file before the user's code.
#ifndef GLINTLAB_FRAGMENT_GLSL_H
#define GLINTLAB_FRAGMENT_GLSL_H
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_quad : require
#include "glintlab_method_glsl.h"

vec4 glintlab_frag_coord;

// A lane's neighbour across the quad minus itself, signed so that both lanes of a pair get the same
// forward difference (the right / lower pixel minus the left / upper one).
#define GLINTLAB_DERIVATIVES(T)                                                                       \
  T glintlab_dFdx(T v) {                                                                              \
    T o = subgroupQuadSwapHorizontal(v);                                                              \
    return (gl_SubgroupInvocationID & 1u) == 0u ? o - v : v - o;                                      \
  }                                                                                                   \
  T glintlab_dFdy(T v) {                                                                              \
    T o = subgroupQuadSwapVertical(v);                                                                \
    return (gl_SubgroupInvocationID & 2u) == 0u ? o - v : v - o;                                      \
  }                                                                                                   \
  T glintlab_fwidth(T v) { return abs(glintlab_dFdx(v)) + abs(glintlab_dFdy(v)); }
GLINTLAB_DERIVATIVES(float)
GLINTLAB_DERIVATIVES(vec2)
GLINTLAB_DERIVATIVES(vec3)
GLINTLAB_DERIVATIVES(vec4)

vec4 glintlab_texture(sampler1D s, float p) { return textureGrad(s, p, glintlab_dFdx(p), glintlab_dFdy(p)); }
vec4 glintlab_texture(sampler2D s, vec2 p) { return textureGrad(s, p, glintlab_dFdx(p), glintlab_dFdy(p)); }
vec4 glintlab_texture(sampler3D s, vec3 p) { return textureGrad(s, p, glintlab_dFdx(p), glintlab_dFdy(p)); }
vec4 glintlab_texture(sampler2DArray s, vec3 p) {
  return textureGrad(s, p, glintlab_dFdx(p.xy), glintlab_dFdy(p.xy));
}
vec4 glintlab_texture(sampler2D s, vec2 p, float bias) {
  float k = exp2(bias);  // a bias of b levels is a footprint 2^b times as wide
  return textureGrad(s, p, k * glintlab_dFdx(p), k * glintlab_dFdy(p));
}

#define dFdx glintlab_dFdx
#define dFdy glintlab_dFdy
#define dFdxFine glintlab_dFdx
#define dFdyFine glintlab_dFdy
#define dFdxCoarse glintlab_dFdx
#define dFdyCoarse glintlab_dFdy
#define fwidth glintlab_fwidth
#define fwidthFine glintlab_fwidth
#define fwidthCoarse glintlab_fwidth
#define texture glintlab_texture
#define texture2D glintlab_texture
#define gl_FragCoord glintlab_frag_coord
#endif
