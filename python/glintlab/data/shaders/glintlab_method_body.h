// glintlab's method-shader contract, written once for HLSL and GLSL (docs/math/glint_images.md#glint-contract):
// the body of glintlab_method_hlsl.h and glintlab_method_glsl.h, which include glintlab_prelude.h first
// (so GLSL reads float3 as vec3, uint2 as uvec2, frac as fract, ...).
// A method shader defines   float glint(GlintInput g)   or   float3 glint(GlintInput g)
// (GLSL may write vec3; any name given as `entry`); glintlab's wrapper kernel includes the language's
// header before the method's code, fills one GlintInput per pixel from the frame's inputs and stores
// the result. Including it again from the method's own file is harmless.
#ifndef GLINTLAB_METHOD_BODY_H
#define GLINTLAB_METHOD_BODY_H

// Every vector is in world space, float32.
struct GlintInput {
  float3 world_pos;  // the shaded surface point
  float2 uv;         // texture coordinates
  float4 J;          // (du/dx, dv/dx, du/dy, dv/dy): the uv Jacobian per pixel (y down the image)
  float3 n;          // shading normal (unit)
  float3 t;          // tangent along the u axis (unit, orthogonal to n)
  float3 b;          // bitangent n x t
  float3 view;       // camera position - world_pos: NOT normalised (its length is the distance)
  float3 light;      // unit vector from the surface point towards the light (an extended light's centre)
  float3 h;          // unit half vector normalize(normalize(view) + light)
  uint2 pixel;       // (column, row) from the top-left pixel
  uint frame;        // index of the frame along the camera path
  uint seed;         // the realization's seed
  // The light's extent (docs/math/glint_images.md#glint-contract-lights); all 0 for a point or
  // directional light, so a point-light method reads the fields above only.
  uint light_kind;       // GLINTLAB_LIGHT_POINT, GLINTLAB_LIGHT_CAP or GLINTLAB_LIGHT_RECT
  float light_radiance;  // the light's constant radiance
  float2 light_size;     // cap: (half-angle in radians, 0); rectangle: half-widths at unit distance
  float3 light_edge;     // rectangle: unit first axis, orthogonal to light (second: cross(light, light_edge))
};

// light_kind's values.
#define GLINTLAB_LIGHT_POINT 0u
#define GLINTLAB_LIGHT_CAP 1u
#define GLINTLAB_LIGHT_RECT 2u

// The solid angle of the light in steradians: a cap of half-angle a, 2 pi (1 - cos a); a rectangle of
// half-widths (x, y) at unit distance facing the point, 4 atan(x y / sqrt(1 + x^2 + y^2)); 0 for a point.
float glintlab_light_solid_angle(GlintInput g) {
  if (g.light_kind == GLINTLAB_LIGHT_CAP) return 6.28318530717959 * (1.0 - cos(g.light_size.x));
  if (g.light_kind == GLINTLAB_LIGHT_RECT) {
    float x = g.light_size.x, y = g.light_size.y;
    return 4.0 * atan(x * y / sqrt(1.0 + x * x + y * y));
  }
  return 0.0;
}

// A 3D hash of 32-bit words (three rounds of multiply-add mixing and a xor-shift, after Jarzynski and
// Olano's pcg3d): every output bit depends on every input bit.
uint3 glintlab_hash3(uint3 v) {
  v = v * 1664525u + 1013904223u;
  v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
  v ^= v >> 16u;
  v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
  return v;
}

// Three uniform values in [0, 1) for a lattice cell and a seed (24 bits each: exact in float32).
float3 glintlab_cell_values(int3 cell, uint seed) {
  uint3 k = uint3(cell) ^ (uint3(0x9E3779B9u, 0x85EBCA6Bu, 0xC2B2AE35u) * seed);
  return float3(glintlab_hash3(k) >> 8u) * (1.0 / 16777216.0);
}

// Hashed value noise standing in for a 128^3 RGB noise texture read with wrap addressing and
// trilinear filtering at normalised coordinates p: texel centres at (i + 0.5) / 128, values of
// glintlab_cell_values, interpolated linearly in x, then y, then z, in this order (the twins follow it).
float3 glintlab_noise3(float3 p, uint seed) {
  float3 x = p * 128.0 - 0.5;
  float3 i = floor(x);
  float3 f = x - i;
  int3 c = int3(i);
  float3 v000 = glintlab_cell_values((c + int3(0, 0, 0)) & 127, seed);
  float3 v100 = glintlab_cell_values((c + int3(1, 0, 0)) & 127, seed);
  float3 v010 = glintlab_cell_values((c + int3(0, 1, 0)) & 127, seed);
  float3 v110 = glintlab_cell_values((c + int3(1, 1, 0)) & 127, seed);
  float3 v001 = glintlab_cell_values((c + int3(0, 0, 1)) & 127, seed);
  float3 v101 = glintlab_cell_values((c + int3(1, 0, 1)) & 127, seed);
  float3 v011 = glintlab_cell_values((c + int3(0, 1, 1)) & 127, seed);
  float3 v111 = glintlab_cell_values((c + int3(1, 1, 1)) & 127, seed);
  float3 x00 = v000 + (v100 - v000) * f.x;
  float3 x10 = v010 + (v110 - v010) * f.x;
  float3 x01 = v001 + (v101 - v001) * f.x;
  float3 x11 = v011 + (v111 - v011) * f.x;
  float3 y0 = x00 + (x10 - x00) * f.y;
  float3 y1 = x01 + (x11 - x01) * f.y;
  return y0 + (y1 - y0) * f.z;
}

#endif
