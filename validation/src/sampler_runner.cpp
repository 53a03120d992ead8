// Shader samplers (glintlab/validation/sampler_shader.hpp): glintlab's wrapper kernel around the user's
// sample_h and pdf_h, compiled and run by the shader-law runner with its own wrapper and its raw-row
// path (Kernel::run_rows), as method shaders are (method_runner.cpp).
#include "glintlab/validation/sampler_shader.hpp"

#include "glintlab/errors.hpp"

#include <sstream>

namespace glintlab::shader {
namespace {

constexpr unsigned kGroupSize = 64;

// The body of main: reads row i (f converts a word to float), calls one of the two functions by the
// mode word and stores four floats.
std::string body(const std::string& f, const std::string& v2, const std::string& v3, const std::string& v4,
                 const std::string& sample_entry, const std::string& pdf_entry) {
  auto w = [&](int k) { return f + "(glintlab_in[b + " + std::to_string(k) + "u])"; };
  auto vec = [&](const std::string& type, int k, int n) {
    std::string out = type + "(";
    for (int j = 0; j < n; ++j) out += (j ? ", " : "") + w(k + j);
    return out + ")";
  };
  std::ostringstream s;
  s << "  uint b = i * glintlab_push.in_stride;\n"
    << "  uint o = i * glintlab_push.out_stride;\n"
    << "  " << v2 << " uv = " << vec(v2, 0, 2) << ";\n"
    << "  " << v4 << " J = " << vec(v4, 2, 4) << ";\n"
    << "  " << v3 << " wo = " << vec(v3, 6, 3) << ";\n"
    << "  if (glintlab_in[b + 9u] == 0u) {\n"
    << "    " << v4 << " r = " << sample_entry << "(uv, J, wo, " << vec(v4, 10, 4) << ");\n"
    << "    glintlab_out[o] = r.x; glintlab_out[o + 1u] = r.y; glintlab_out[o + 2u] = r.z; glintlab_out[o + 3u] = "
       "r.w;\n"
    << "  } else {\n"
    << "    float p = " << pdf_entry << "(uv, J, wo, " << vec(v3, 10, 3) << ");\n"
    << "    glintlab_out[o] = p; glintlab_out[o + 1u] = 0.0; glintlab_out[o + 2u] = 0.0; glintlab_out[o + 3u] = 0.0;\n"
    << "  }\n";
  return s.str();
}

}  // namespace

std::string sampler_signature(const std::string& language, const std::string& sample_entry,
                              const std::string& pdf_entry) {
  return language == "hlsl" ? "float4 " + sample_entry + "(float2 uv, float4 J, float3 wo, float4 u) and float " +
                                  pdf_entry + "(float2 uv, float4 J, float3 wo, float3 h)"
                            : "vec4 " + sample_entry + "(vec2 uv, vec4 J, vec3 wo, vec4 u) and float " + pdf_entry +
                                  "(vec2 uv, vec4 J, vec3 wo, vec3 h)";
}

std::string sampler_wrapper_source(const std::string& language, const std::string& sample_entry,
                                   const std::string& pdf_entry, const std::string& include_name) {
  std::ostringstream s;
  if (language == "hlsl") {
    s << "#include \"glintlab_sampler_hlsl.h\"\n"
      << "#include \"" << include_name << "\"\n"
      << "struct GlintlabPush { uint count; uint in_stride; uint out_stride; uint pad; };\n"
      // A ConstantBuffer<>, as the method wrapper (a plain struct would become a uniform buffer).
      << "[[vk::push_constant]] ConstantBuffer<GlintlabPush> glintlab_push;\n"
      << "[[vk::binding(0, 0)]] StructuredBuffer<uint> glintlab_in;\n"
      << "[[vk::binding(3, 0)]] RWStructuredBuffer<float> glintlab_out;\n"
      << "[numthreads(" << kGroupSize << ", 1, 1)]\n"
      << "void glintlab_main(uint3 glintlab_id : SV_DispatchThreadID) {\n"
      << "  uint i = glintlab_id.x;\n"
      << "  if (i >= glintlab_push.count) return;\n"
      << body("asfloat", "float2", "float3", "float4", sample_entry, pdf_entry) << "}\n";
  } else {
    s << "#version 450\n"
      << "#extension GL_GOOGLE_include_directive : require\n"
      << "#include \"glintlab_sampler_glsl.h\"\n"
      << "#include \"" << include_name << "\"\n"
      << "layout(local_size_x = " << kGroupSize << ") in;\n"
      << "layout(push_constant) uniform GlintlabPush { uint count; uint in_stride; uint out_stride; uint pad; } "
         "glintlab_push;\n"
      << "layout(std430, set = 0, binding = 0) readonly buffer GlintlabIn { uint glintlab_in[]; };\n"
      << "layout(std430, set = 0, binding = 3) writeonly buffer GlintlabOut { float glintlab_out[]; };\n"
      << "void main() {\n"
      << "  uint i = gl_GlobalInvocationID.x;\n"
      << "  if (i >= glintlab_push.count) return;\n"
      << body("uintBitsToFloat", "vec2", "vec3", "vec4", sample_entry, pdf_entry) << "}\n";
  }
  return s.str();
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
  const std::vector<SpirvResource> allowed{{"glintlab_push", "push constant", -1, -1},
                                           {"glintlab_in", "storage buffer", 0, 0},
                                           {"GlintlabIn", "storage buffer", 0, 0},
                                           {"glintlab_out", "storage buffer", 0, 3},
                                           {"GlintlabOut", "storage buffer", 0, 3}};
  return std::make_shared<Kernel>(spec, sampler_wrapper_source(spec.language, spec.entry, pdf_entry, spec.source_name),
                                  sampler_signature(spec.language, spec.entry, pdf_entry), allowed);
}

void run_sampler(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s) {
  kernel.run_rows(in, kSamplerInputWords, count, out, kSamplerOutputWords, timeout_s);
}

}  // namespace glintlab::shader
