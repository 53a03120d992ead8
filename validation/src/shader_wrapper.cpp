// The one generator of wrapper kernels (glintlab/validation/shader.hpp): a kind's declaration, written
// once in GLSL's spelling, as an HLSL or a GLSL compute kernel; its resources and its signature. The
// counting law's declaration lives here too (the method shader's in method_runner.cpp, the shader
// sampler's in sampler_runner.cpp).
#include "glintlab/validation/shader.hpp"

#include <cctype>
#include <sstream>
#include <stdexcept>

namespace glintlab::shader {
namespace {

bool identifier_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// `glsl` in `language`: HLSL's type names and bit cast replace GLSL's, whole words only; then $0, $1
// become the entries' names (after the replacement: an entry is never renamed).
std::string spelled(const std::string& glsl, const std::string& language, const std::vector<std::string>& entries) {
  static const std::pair<std::string, std::string> kHlsl[] = {
      {"vec2", "float2"}, {"vec3", "float3"}, {"vec4", "float4"}, {"uvec2", "uint2"}, {"uintBitsToFloat", "asfloat"}};
  std::string out;
  out.reserve(glsl.size());
  for (std::size_t i = 0; i < glsl.size();) {
    const char c = glsl[i];
    if (c == '$' && i + 1 < glsl.size() && std::isdigit(static_cast<unsigned char>(glsl[i + 1]))) {
      const auto k = static_cast<std::size_t>(glsl[i + 1] - '0');
      if (k >= entries.size()) throw std::logic_error("wrapper declaration: $" + std::to_string(k) + " has no entry");
      out += entries[k];
      i += 2;
      continue;
    }
    if (!identifier_char(c)) {
      out += c;
      ++i;
      continue;
    }
    std::size_t e = i;
    while (e < glsl.size() && identifier_char(glsl[e])) ++e;
    std::string word = glsl.substr(i, e - i);
    if (language == "hlsl")
      for (const auto& [from, to] : kHlsl)
        if (word == from) word = to;
    out += word;
    i = e;
  }
  return out;
}

int words_of(const std::string& type) {
  if (type == "float" || type == "uint") return 1;
  if (type == "vec2" || type == "uvec2") return 2;
  if (type == "vec3") return 3;
  if (type == "vec4") return 4;
  throw std::logic_error("wrapper declaration: field type '" + type + "'");
}

// A field's value in GLSL's spelling: its own expression, or its words of the row (float32 bits
// through uintBitsToFloat, integers as they are).
std::string field_value(const WrapperField& f, const std::string& row) {
  if (!f.read.empty()) return f.read;
  const bool integer = f.type[0] == 'u';
  auto word = [&](int k) {
    const std::string w = row + "[b + " + std::to_string(f.word + k) + "u]";
    return integer ? w : "uintBitsToFloat(" + w + ")";
  };
  const int n = words_of(f.type);
  if (n == 1) return word(0);
  std::string out = f.type + "(";
  for (int k = 0; k < n; ++k) out += (k ? ", " : "") + word(k);
  return out + ")";
}

// main's body from its row checks on: the fields (into the record or as locals), then the call.
std::string body(const WrapperDeclaration& kind) {
  std::string row;
  for (const auto& b : kind.buffers)
    if (b.binding == 0) row = b.variable;
  std::ostringstream s;
  bool words = false;
  for (const auto& f : kind.fields) words = words || f.read.empty();
  if (words) s << "  uint b = i * glintlab_push." << kind.push.at(0) << ";\n";
  std::string member;  // "g." when the fields are the record's members
  if (!kind.record.empty()) {
    s << "  " << kind.record << ";\n";
    member = kind.record.substr(kind.record.find_last_of(' ') + 1) + ".";
  }
  for (const auto& f : kind.fields) {
    if (member.empty() && (f.name == "b" || f.name == "i"))
      throw std::logic_error("wrapper declaration: a local field named '" + f.name + "' (the kernel's own)");
    s << "  " << (member.empty() ? f.type + " " + f.name : member + f.name) << " = " << field_value(f, row) << ";\n";
  }
  s << kind.call;
  return s.str();
}

}  // namespace

std::string generate_wrapper(const WrapperDeclaration& kind, const std::string& language,
                             const std::string& include_name) {
  if (kind.push.size() != 3) throw std::logic_error("wrapper declaration: the push constant has 3 words after count");
  std::string push = "uint count;";
  for (const auto& w : kind.push) push += " uint " + w + ";";
  std::ostringstream s;
  if (language == "hlsl") {
    // The push constant is a ConstantBuffer<>: glslang puts a plain global struct marked
    // [[vk::push_constant]] into the "$Global" uniform buffer at set 0, binding 0 instead (where
    // binding 0's storage buffer is), which the resource check refuses.
    if (!kind.header.empty()) s << "#include \"" << kind.header << "_hlsl.h\"\n";
    s << "#include \"" << include_name << "\"\n"
      << "struct GlintlabPush { " << push << " };\n"
      << "[[vk::push_constant]] ConstantBuffer<GlintlabPush> glintlab_push;\n";
    for (const auto& b : kind.buffers)
      s << "[[vk::binding(" << b.binding << ", 0)]] " << (b.written ? "RW" : "") << "StructuredBuffer<"
        << spelled(b.element, language, {}) << "> " << b.variable << ";\n";
    s << spelled(kind.helpers, language, kind.entries) << "[numthreads(" << kWorkGroupSize << ", 1, 1)]\n"
      << "void glintlab_main(uint3 glintlab_id : SV_DispatchThreadID) {\n"
      << "  uint i = glintlab_id.x;\n";
  } else {
    s << "#version 450\n"
      << "#extension GL_GOOGLE_include_directive : require\n";
    if (!kind.header.empty()) s << "#include \"" << kind.header << "_glsl.h\"\n";
    s << "#include \"" << include_name << "\"\n"
      << "layout(local_size_x = " << kWorkGroupSize << ") in;\n"
      << "layout(push_constant) uniform GlintlabPush { " << push << " } glintlab_push;\n";
    for (const auto& b : kind.buffers)
      s << "layout(std430, set = 0, binding = " << b.binding << ") " << (b.written ? "writeonly" : "readonly")
        << " buffer " << b.block << " { " << b.element << " " << b.variable << "[]; };\n";
    s << kind.helpers << "void main() {\n"
      << "  uint i = gl_GlobalInvocationID.x;\n";
  }
  s << "  if (i >= glintlab_push.count) return;\n" << spelled(body(kind), language, kind.entries) << "}\n";
  return s.str();
}

std::string wrapper_signature(const WrapperDeclaration& kind, const std::string& language) {
  return spelled(kind.signature, language, kind.entries);
}

std::vector<SpirvResource> wrapper_resources(const WrapperDeclaration& kind) {
  // HLSL names its buffers' variables; GLSL's blocks are anonymous, so their block type names count.
  std::vector<SpirvResource> out{{"glintlab_push", "push constant", -1, -1}};
  for (const auto& b : kind.buffers) {
    out.push_back({b.variable, "storage buffer", 0, b.binding});
    out.push_back({b.block, "storage buffer", 0, b.binding});
  }
  return out;
}

// Bindings: 0 n, 1 p (one float per row, or one for all: stride 0), 2 u (vec4 per row), 3 the counts.
WrapperDeclaration law_wrapper(const std::string& entry) {
  WrapperDeclaration d;
  d.push = {"n_stride", "p_stride", "pad"};
  d.buffers = {{0, "glintlab_n", "GlintlabN", "float", false},
               {1, "glintlab_p", "GlintlabP", "float", false},
               {2, "glintlab_u", "GlintlabU", "vec4", false},
               {3, "glintlab_k", "GlintlabK", "float", true}};
  d.fields = {{"n", "float", "glintlab_n[i * glintlab_push.n_stride]"},
              {"p", "float", "glintlab_p[i * glintlab_push.p_stride]"},
              {"u", "vec4", "glintlab_u[i]"}};
  d.call = "  glintlab_k[i] = $0(n, p, u);\n";
  d.signature = "float $0(float n, float p, vec4 u)";
  d.entries = {entry};
  return d;
}

std::string wrapper_source(const std::string& language, const std::string& entry, const std::string& include_name) {
  return generate_wrapper(law_wrapper(entry), language, include_name);
}

}  // namespace glintlab::shader
