// Shader samplers (glintlab/validation/sampler_shader.hpp): the sampler's declarations (its row's words,
// the mode's two calls), from which the one generator writes the wrapper kernel around the user's
// sample_h and pdf_h, or sample_l and pdf_l; compiled and run by the shader runner on its row path (Kernel::run_rows),
// as method shaders are (method_runner.cpp).
#include "glintlab/validation/sampler_shader.hpp"

#include <algorithm>
#include <regex>

#include "glintlab/base/errors.hpp"

namespace glintlab::shader {

namespace {

// The two contracts' wrappers differ only in the name of the mode's vector and in the signatures
// they state: the rows are the same, so one builder serves both (and the probe below).
WrapperDeclaration sampler_declaration(const std::string& sample_entry, const std::string& pdf_entry,
                                       const std::string& vector) {
  WrapperDeclaration d;
  d.header = "glintlab_sampler";
  d.push = {"in_stride", "out_stride", "pad"};
  d.buffers = {{0, "glintlab_in", "GlintlabIn", "uint", false}, {3, "glintlab_out", "GlintlabOut", "float", true}};
  // The row's words (kSamplerInputWords; docs/math/sampling.md#shader-samplers).
  d.fields = {{"uv", "vec2", 0},   {"J", "vec4", 2},  {"wo", "vec3", 6},
              {"mode", "uint", 9}, {"u", "vec4", 10}, {vector, "vec3", 10}};
  d.call =
      "  uint o = i * glintlab_push.out_stride;\n"
      "  if (mode == 0u) {\n"
      "    vec4 r = $0(uv, J, wo, u);\n"
      "    glintlab_out[o] = r.x; glintlab_out[o + 1u] = r.y; glintlab_out[o + 2u] = r.z; glintlab_out[o + 3u] = r.w;\n"
      "  } else {\n"
      "    float p = $1(uv, J, wo, " +
      vector +
      ");\n"
      "    glintlab_out[o] = p; glintlab_out[o + 1u] = 0.0; glintlab_out[o + 2u] = 0.0; glintlab_out[o + 3u] = 0.0;\n"
      "  }\n";
  d.signature = "vec4 $0(vec2 uv, vec4 J, vec3 wo, vec4 u) and float $1(vec2 uv, vec4 J, vec3 wo, vec3 " + vector + ")";
  d.entries = {sample_entry, pdf_entry};
  return d;
}

const char* contract_vector(const std::string& contract) {
  if (contract == "h") return "h";
  if (contract == "l") return "l";
  glintlab::throw_invalid("", "contract", "'" + contract + "'", "'h' (sample_h, pdf_h) or 'l' (sample_l, pdf_l)");
}

}  // namespace

// The wrapper reads uv, J, wo, the mode and the mode's vector (u or h, both at word 10) from the row and
// calls sample_h (mode 0: four floats out) or pdf_h (mode 1: the pdf, then zeros).
WrapperDeclaration sampler_wrapper(const std::string& sample_entry, const std::string& pdf_entry) {
  return sampler_declaration(sample_entry, pdf_entry, "h");
}

// The reflected-direction contract: the same rows, the mode's vector a reflected direction l (word 10),
// sample_l returning (l.xyz, pdf of l) and pdf_l the pdf of l, each per steradian of l.
WrapperDeclaration sampler_l_wrapper(const std::string& sample_entry, const std::string& pdf_entry) {
  return sampler_declaration(sample_entry, pdf_entry, "l");
}

std::vector<std::string> sampler_functions(KernelSpec spec) {
  validate_spec(spec);
  // The probe: glintlab's sampler header and the user's code before an empty main, preprocessed with
  // the spec's defines and include folders (the runner's own step), so that functions defined in an
  // included file, or left out by an #ifdef, are seen as the compiler will see them.
  WrapperDeclaration probe = sampler_declaration("", "", "h");
  probe.fields.clear();
  probe.call.clear();
  const std::string text = preprocess(spec, generate_wrapper(probe, spec.language, spec.source_name));
  // A declaration is a type name, the function's name and its parameter list; a call is not preceded by
  // a type (`return pdf_h(h)`, `p = pdf_h(h)`).
  static const std::regex kDeclared(R"(([A-Za-z_]\w*)\s+(sample_h|pdf_h|sample_l|pdf_l)\s*\()");
  std::vector<std::string> out;
  for (std::sregex_iterator it(text.begin(), text.end(), kDeclared), end; it != end; ++it) {
    const std::string type = (*it)[1], name = (*it)[2];
    if (type != "return" && std::find(out.begin(), out.end(), name) == out.end()) out.push_back(name);
  }
  return out;
}

std::string sampler_signature(const std::string& language, const std::string& sample_entry,
                              const std::string& pdf_entry, const std::string& contract) {
  return wrapper_signature(sampler_declaration(sample_entry, pdf_entry, contract_vector(contract)), language);
}

std::string sampler_wrapper_source(const std::string& language, const std::string& sample_entry,
                                   const std::string& pdf_entry, const std::string& include_name,
                                   const std::string& contract) {
  return generate_wrapper(sampler_declaration(sample_entry, pdf_entry, contract_vector(contract)), language,
                          include_name);
}

std::shared_ptr<Kernel> sampler_kernel(KernelSpec spec, const std::string& pdf_entry, const std::string& contract) {
  const std::string vector = contract_vector(contract);
  if (spec.language != "hlsl" && spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'hlsl' or 'glsl'");
  validate_spec(spec);  // the sample entry among the rest
  bool ident = !pdf_entry.empty() && !(pdf_entry[0] >= '0' && pdf_entry[0] <= '9');
  for (char c : pdf_entry)
    ident = ident && (c == '_' || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9'));
  if (!ident) glintlab::throw_invalid("", "pdf_entry", "'" + pdf_entry + "'", "a function name");
  spec.n_uniforms = 0;  // the wrapper reads its own uniforms from the rows
  return std::make_shared<Kernel>(spec, sampler_declaration(spec.entry, pdf_entry, vector));
}

void run_sampler(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s) {
  kernel.run_rows(in, kSamplerInputWords, count, out, kSamplerOutputWords, timeout_s);
}

}  // namespace glintlab::shader
