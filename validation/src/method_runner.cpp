// Method shaders (glintlab/validation/method_shader.hpp): glintlab's wrapper kernel around the user's
// per-pixel glint function, compiled and run by the shader-law runner with its own wrapper and its
// raw-row path (Kernel::run_rows), so that compilation, caching, devices and timeouts are shared.
#include "glintlab/validation/method_shader.hpp"

#include "glintlab/errors.hpp"

#include <sstream>
#include <stdexcept>

namespace glintlab::shader {
namespace {

constexpr unsigned kGroupSize = 64;

// Reads the 32-word row of pixel i into a GlintInput. `f` converts a word to float (GLSL
// uintBitsToFloat, HLSL asfloat); the integers are the words themselves.
std::string fill_input(const std::string& f, const std::string& buf, const std::string& v2, const std::string& v3,
                       const std::string& v4, const std::string& u2) {
  std::ostringstream s;
  auto w = [&](int k) { return f + "(" + buf + "[b + " + std::to_string(k) + "u])"; };
  auto vec = [&](const std::string& type, int k, int n) {
    std::string out = type + "(";
    for (int j = 0; j < n; ++j) out += (j ? ", " : "") + w(k + j);
    return out + ")";
  };
  s << "  g.world_pos = " << vec(v3, 0, 3) << ";\n"
    << "  g.uv = " << vec(v2, 3, 2) << ";\n"
    << "  g.J = " << vec(v4, 5, 4) << ";\n"
    << "  g.n = " << vec(v3, 9, 3) << ";\n"
    << "  g.t = " << vec(v3, 12, 3) << ";\n"
    << "  g.b = " << vec(v3, 15, 3) << ";\n"
    << "  g.view = " << vec(v3, 18, 3) << ";\n"
    << "  g.light = " << vec(v3, 21, 3) << ";\n"
    << "  g.h = " << vec(v3, 24, 3) << ";\n"
    << "  g.pixel = " << u2 << "(" << buf << "[b + 27u], " << buf << "[b + 28u]);\n"
    << "  g.frame = " << buf << "[b + 29u];\n"
    << "  g.seed = " << buf << "[b + 30u];\n";
  return s.str();
}

std::string method_signature(const std::string& language, const std::string& entry) {
  return language == "hlsl" ? "float " + entry + "(GlintInput g) or float3 " + entry + "(GlintInput g)"
                            : "float " + entry + "(GlintInput g) or vec3 " + entry + "(GlintInput g)";
}

}  // namespace

std::string method_wrapper_source(const std::string& language, const std::string& entry,
                                  const std::string& include_name) {
  std::ostringstream s;
  if (language == "hlsl") {
    s << "#include \"glintlab_method_hlsl.h\"\n"
      << "#include \"" << include_name << "\"\n"
      << "struct GlintlabPush { uint count; uint in_stride; uint out_stride; uint pad; };\n"
      // A ConstantBuffer<>: a plain struct marked [[vk::push_constant]] becomes glslang's "$Global"
      // uniform buffer at set 0, binding 0 (over glintlab_in), not a push constant.
      << "[[vk::push_constant]] ConstantBuffer<GlintlabPush> glintlab_push;\n"
      << "[[vk::binding(0, 0)]] StructuredBuffer<uint> glintlab_in;\n"
      << "[[vk::binding(3, 0)]] RWStructuredBuffer<float> glintlab_out;\n"
      << "void glintlab_store(uint o, float v) { glintlab_out[o] = v; glintlab_out[o + 1u] = v; "
         "glintlab_out[o + 2u] = v; glintlab_out[o + 3u] = 1.0; }\n"
      << "void glintlab_store(uint o, float3 v) { glintlab_out[o] = v.x; glintlab_out[o + 1u] = v.y; "
         "glintlab_out[o + 2u] = v.z; glintlab_out[o + 3u] = 3.0; }\n"
      << "[numthreads(" << kGroupSize << ", 1, 1)]\n"
      << "void glintlab_main(uint3 glintlab_id : SV_DispatchThreadID) {\n"
      << "  uint i = glintlab_id.x;\n"
      << "  if (i >= glintlab_push.count) return;\n"
      << "  uint b = i * glintlab_push.in_stride;\n"
      << "  GlintInput g;\n"
      << fill_input("asfloat", "glintlab_in", "float2", "float3", "float4", "uint2")
      << "  glintlab_store(i * glintlab_push.out_stride, " << entry << "(g));\n"
      << "}\n";
  } else {
    s << "#version 450\n"
      << "#extension GL_GOOGLE_include_directive : require\n"
      << "#include \"glintlab_method_glsl.h\"\n"
      << "#include \"" << include_name << "\"\n"
      << "layout(local_size_x = " << kGroupSize << ") in;\n"
      << "layout(push_constant) uniform GlintlabPush { uint count; uint in_stride; uint out_stride; uint pad; } "
         "glintlab_push;\n"
      << "layout(std430, set = 0, binding = 0) readonly buffer GlintlabIn { uint glintlab_in[]; };\n"
      << "layout(std430, set = 0, binding = 3) writeonly buffer GlintlabOut { float glintlab_out[]; };\n"
      << "void glintlab_store(uint o, float v) { glintlab_out[o] = v; glintlab_out[o + 1u] = v; "
         "glintlab_out[o + 2u] = v; glintlab_out[o + 3u] = 1.0; }\n"
      << "void glintlab_store(uint o, vec3 v) { glintlab_out[o] = v.x; glintlab_out[o + 1u] = v.y; "
         "glintlab_out[o + 2u] = v.z; glintlab_out[o + 3u] = 3.0; }\n"
      << "void main() {\n"
      << "  uint i = gl_GlobalInvocationID.x;\n"
      << "  if (i >= glintlab_push.count) return;\n"
      << "  uint b = i * glintlab_push.in_stride;\n"
      << "  GlintInput g;\n"
      << fill_input("uintBitsToFloat", "glintlab_in", "vec2", "vec3", "vec4", "uvec2")
      << "  glintlab_store(i * glintlab_push.out_stride, " << entry << "(g));\n"
      << "}\n";
  }
  return s.str();
}

std::shared_ptr<Kernel> method_kernel(KernelSpec spec) {
  if (spec.language != "hlsl" && spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'hlsl' or 'glsl'");
  spec.n_uniforms = 0;
  // The wrapper's own resources (HLSL names its variables, GLSL its blocks); a method shader may
  // declare no other (Kernel refuses it by name before the driver sees it).
  const std::vector<SpirvResource> allowed{{"glintlab_push", "push constant", -1, -1},
                                           {"glintlab_in", "storage buffer", 0, 0},
                                           {"GlintlabIn", "storage buffer", 0, 0},
                                           {"glintlab_out", "storage buffer", 0, 3},
                                           {"GlintlabOut", "storage buffer", 0, 3}};
  return std::make_shared<Kernel>(spec, method_wrapper_source(spec.language, spec.entry, spec.source_name),
                                  method_signature(spec.language, spec.entry), allowed);
}

void run_method(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s) {
  kernel.run_rows(in, kMethodInputWords, count, out, kMethodOutputWords, timeout_s);
}

}  // namespace glintlab::shader
