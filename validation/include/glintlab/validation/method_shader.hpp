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

// ---------------------------------------------------------------- fragment mode
// A fragment shader's glint code as written (docs/guide/shaders.md#shaders-fragment): the user's
// `void main()` (renamed glintlab_fragment_main by the Python layer, which also turns its `in`/`out`
// globals into plain globals and its loose uniforms into uniform blocks) runs in a compute kernel with
// four invocations per pixel, a quad: lane 0 the pixel, lane 1 one pixel right, lane 2 one pixel down,
// lane 3 both, each lane's inputs moved by the pixel's differentials. dFdx, dFdy and fwidth are then the
// differences across the quad (subgroup quad operations), as a GPU's fragment derivatives are, and
// texture() picks its mip level from them. The row: GlintInput's kMethodInputWords words, then the
// differentials, from word kMethodInputWords (W) on:
//   W..W+2 dpdx   W+3..W+5 dpdy (world position per pixel)   W+6..W+8 dndx   W+9..W+11 dndy (shading normal)
constexpr std::size_t kFragmentInputWords = kMethodInputWords + 12;

// The fragment mode's declaration: `assign` is GLSL run in each lane before the call, setting the user's
// globals from the lane's values (glintlab_world_pos, glintlab_uv, glintlab_J, glintlab_n, glintlab_t,
// glintlab_b, glintlab_view, glintlab_light, glintlab_h, glintlab_pixel, glintlab_frame, glintlab_seed,
// and gl_FragCoord's glintlab_frag_coord); `output` is the expression stored after it (lane 0, as vec3).
WrapperDeclaration fragment_wrapper(const std::string& assign, const std::string& output);
std::string fragment_wrapper_source(const std::string& assign, const std::string& output,
                                    const std::string& include_name);
// Compiles a fragment-mode shader (GLSL only; spec.source already adapted).
std::shared_ptr<Kernel> fragment_kernel(KernelSpec spec, const std::string& assign, const std::string& output);
// out (count x kMethodOutputWords) from in (count x kFragmentInputWords): four invocations per row.
void run_fragment(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s);

}  // namespace glintlab::shader
