// Shader samplers: a direction sampler written as two shader functions (HLSL shown; GLSL writes vec2,
// vec3, vec4), on half vectors (contract "h")
//     float4 sample_h(float2 uv, float4 J, float3 wo, float4 u)   -> (h.xyz, pdf of h per steradian)
//     float  pdf_h(float2 uv, float4 J, float3 wo, float3 h)      -> pdf of h per steradian
// or on reflected directions, as engines write them (contract "l")
//     float4 sample_l(float2 uv, float4 J, float3 wo, float4 u)   -> (l.xyz, pdf of l per steradian)
//     float  pdf_l(float2 uv, float4 J, float3 wo, float3 l)      -> pdf of l per steradian
// run by the shader-law runner (glintlab/validation/shader.hpp) inside glintlab's own compute kernel,
// so that compilation, caching, resource and loop checks, devices and timeouts are the runner's
// (docs/math/sampling.md#shader-samplers). The include file glintlab ships
// (python/glintlab/data/shaders/glintlab_sampler_hlsl.h, glintlab_sampler_glsl.h) comes before the
// user's code.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "glintlab/validation/shader.hpp"

namespace glintlab::shader {

// One row of the input buffer: 16 words, float32 bits except the mode.
//   0..1 uv   2..5 J (du/dx, dv/dx, du/dy, dv/dy)   6..8 wo   9 mode (uint: 0 sample_h, 1 pdf_h)
//   10..13 u (the four uniforms, mode 0) or 10..12 h (mode 1)   14..15 unused
// (contract "l": sample_l, pdf_l and l in place of h).
// One kernel serves both calls (one compile, one pipeline): the mode word picks the function.
constexpr std::size_t kSamplerInputWords = 16;
// One row of the output: sample_h's (h.x, h.y, h.z, pdf) in mode 0, (pdf, 0, 0, 0) in mode 1.
constexpr std::size_t kSamplerOutputWords = 4;

// The shader sampler's wrapper declaration (glintlab/validation/shader.hpp): the row's words, and the
// mode word choosing the call of sample_h or of pdf_h.
WrapperDeclaration sampler_wrapper(const std::string& sample_entry, const std::string& pdf_entry);
// The reflected-direction contract's declaration: the same rows, the vector of mode 1 is l.
WrapperDeclaration sampler_l_wrapper(const std::string& sample_entry, const std::string& pdf_entry);

// Which of sample_h, pdf_h, sample_l, pdf_l the code declares (in the order first declared), read from
// its preprocessed text (its #includes and spec.defines expanded, as the compiler will see it): how
// gl.shader_sampler picks the contract. Throws as preprocess does.
std::vector<std::string> sampler_functions(KernelSpec spec);

// The expected signatures of the two functions of `contract` ("h" or "l"), as compile errors name them.
std::string sampler_signature(const std::string& language, const std::string& sample_entry,
                              const std::string& pdf_entry, const std::string& contract = "h");

// The wrapper kernel around the user's two functions (for the docs and for tests).
std::string sampler_wrapper_source(const std::string& language, const std::string& sample_entry,
                                   const std::string& pdf_entry, const std::string& include_name,
                                   const std::string& contract = "h");

// Compiles a shader sampler of `contract` ("h": spec.entry is sample_h and `pdf_entry` pdf_h; "l":
// sample_l and pdf_l); spec.include_dirs must contain the folder of glintlab's sampler include files.
// Compile errors and a missing or mistyped function are std::invalid_argument errors (the compiler's
// messages, file:line).
std::shared_ptr<Kernel> sampler_kernel(KernelSpec spec, const std::string& pdf_entry = "pdf_h",
                                       const std::string& contract = "h");

// out (count x kSamplerOutputWords) = the kernel applied to each row of in (count x kSamplerInputWords).
void run_sampler(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s);

}  // namespace glintlab::shader
