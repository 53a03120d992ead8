// Method shaders: a whole per-pixel glint method written as one shader function,
//     float glint(GlintInput g)      or      float3 glint(GlintInput g)   (GLSL: vec3)
// run by the shader-law runner (glintlab/validation/shader.hpp) inside glintlab's own compute kernel,
// over the per-pixel inputs of a frame (docs/math/glint_images.md#glint-contract). GlintInput is
// declared by the include file glintlab ships (python/glintlab/data/shaders/glintlab_method_hlsl.h,
// glintlab_method_glsl.h), which the wrapper includes before the user's code.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "glintlab/validation/shader.hpp"

namespace glintlab::shader {

// One row of the input buffer: 38 words per pixel. Floats in float32, the integers' bits in the
// following words (the wrapper reads the buffer as uint and converts).
//   0..2 world_pos   3..4 uv   5..8 J (du/dx, dv/dx, du/dy, dv/dy)   9..11 n   12..14 t   15..17 b
//   18..20 view (unnormalised, surface to camera)   21..23 light (unit, towards the light's centre)
//   24..26 h (unit)   27..28 pixel (uint column, row from the top left)   29 frame (uint)   30 seed (uint)
//   31 light_kind (uint: 0 point or directional, 1 cap, 2 rectangle)   32 light_radiance
//   33..34 light_size (cap: half-angle, 0; rectangle: half-widths at unit distance)
//   35..37 light_edge (unit, the rectangle's first axis, orthogonal to light)
// A point light leaves words 31..37 zero: the point-light contract of the first 31 words is unchanged.
constexpr std::size_t kMethodInputWords = 38;
// One row of the output buffer: (r, g, b, channels); a float result is written to r, g and b with
// channels = 1, a float3 result with channels = 3.
constexpr std::size_t kMethodOutputWords = 4;

// The method shader's wrapper declaration (glintlab/validation/shader.hpp): GlintInput's fields at
// their words of the row, the float or float3 result stored with its channel count.
WrapperDeclaration method_wrapper(const std::string& entry);

// The wrapper kernel around the user's `entry` (for the docs and for tests).
std::string method_wrapper_source(const std::string& language, const std::string& entry,
                                  const std::string& include_name);

// Compiles a method shader: spec.source is the user's code defining `spec.entry`; spec.include_dirs
// must contain the folder of glintlab's GlintInput include files. Compile errors throw
// std::invalid_argument naming the expected signature.
std::shared_ptr<Kernel> method_kernel(KernelSpec spec);

// out (count x kMethodOutputWords) = the entry applied to each row of in (count x kMethodInputWords).
void run_method(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s);

}  // namespace glintlab::shader
