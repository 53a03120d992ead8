// Shader samplers (glintlab/validation/sampler_shader.hpp): the sampler's declaration (its row's words,
// the mode's two calls), from which the one generator writes the wrapper kernel around the user's
// sample_h and pdf_h; compiled and run by the shader runner on its row path (Kernel::run_rows), as
// method shaders are (method_runner.cpp).
#include "glintlab/validation/sampler_shader.hpp"

#include "glintlab/errors.hpp"

namespace glintlab::shader {

// The wrapper reads uv, J, wo, the mode and the mode's vector (u or h, both at word 10) from the row and
// calls sample_h (mode 0: four floats out) or pdf_h (mode 1: the pdf, then zeros).
WrapperDeclaration sampler_wrapper(const std::string& sample_entry, const std::string& pdf_entry) {
  WrapperDeclaration d;
  d.header = "glintlab_sampler";
  d.push = {"in_stride", "out_stride", "pad"};
  d.buffers = {{0, "glintlab_in", "GlintlabIn", "uint", false}, {3, "glintlab_out", "GlintlabOut", "float", true}};
  // The row's words (kSamplerInputWords; docs/math/sampling.md#shader-samplers).
  d.fields = {{"uv", "vec2", 0},   {"J", "vec4", 2},  {"wo", "vec3", 6},
              {"mode", "uint", 9}, {"u", "vec4", 10}, {"h", "vec3", 10}};
  d.call =
      "  uint o = i * glintlab_push.out_stride;\n"
      "  if (mode == 0u) {\n"
      "    vec4 r = $0(uv, J, wo, u);\n"
      "    glintlab_out[o] = r.x; glintlab_out[o + 1u] = r.y; glintlab_out[o + 2u] = r.z; glintlab_out[o + 3u] = r.w;\n"
      "  } else {\n"
      "    float p = $1(uv, J, wo, h);\n"
      "    glintlab_out[o] = p; glintlab_out[o + 1u] = 0.0; glintlab_out[o + 2u] = 0.0; glintlab_out[o + 3u] = 0.0;\n"
      "  }\n";
  d.signature = "vec4 $0(vec2 uv, vec4 J, vec3 wo, vec4 u) and float $1(vec2 uv, vec4 J, vec3 wo, vec3 h)";
  d.entries = {sample_entry, pdf_entry};
  return d;
}

std::string sampler_signature(const std::string& language, const std::string& sample_entry,
                              const std::string& pdf_entry) {
  return wrapper_signature(sampler_wrapper(sample_entry, pdf_entry), language);
}

std::string sampler_wrapper_source(const std::string& language, const std::string& sample_entry,
                                   const std::string& pdf_entry, const std::string& include_name) {
  return generate_wrapper(sampler_wrapper(sample_entry, pdf_entry), language, include_name);
}

std::shared_ptr<Kernel> sampler_kernel(KernelSpec spec, const std::string& pdf_entry) {
  if (spec.language != "hlsl" && spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'hlsl' or 'glsl'");
  validate_spec(spec);  // the sample entry among the rest
  bool ident = !pdf_entry.empty() && !(pdf_entry[0] >= '0' && pdf_entry[0] <= '9');
  for (char c : pdf_entry)
    ident = ident && (c == '_' || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9'));
  if (!ident) glintlab::throw_invalid("", "pdf_entry", "'" + pdf_entry + "'", "a function name");
  spec.n_uniforms = 0;  // the wrapper reads its own uniforms from the rows
  return std::make_shared<Kernel>(spec, sampler_wrapper(spec.entry, pdf_entry));
}

void run_sampler(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s) {
  kernel.run_rows(in, kSamplerInputWords, count, out, kSamplerOutputWords, timeout_s);
}

}  // namespace glintlab::shader
