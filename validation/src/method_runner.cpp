// Method shaders (glintlab/validation/method_shader.hpp): the method's declaration (GlintInput's fields
// at their words of the row, the glintlab_store overloads), from which the one generator writes the
// wrapper kernel; compiled and run by the shader runner on its row path (Kernel::run_rows), so that
// compilation, caching, devices and timeouts are shared.
#include "glintlab/validation/method_shader.hpp"

#include "glintlab/base/errors.hpp"

namespace glintlab::shader {

// The wrapper reads the row into a GlintInput (declared by glintlab_method_hlsl.h / _glsl.h) and stores
// the entry's float (channels 1) or vec3 (channels 3) through the overload of glintlab_store.
WrapperDeclaration method_wrapper(const std::string& entry) {
  WrapperDeclaration d;
  d.header = "glintlab_method";
  d.push = {"in_stride", "out_stride", "pad"};
  d.buffers = {{0, "glintlab_in", "GlintlabIn", "uint", false}, {3, "glintlab_out", "GlintlabOut", "float", true}};
  d.record = "GlintInput g";
  // GlintInput's fields at their words of the row (kMethodInputWords; docs/math/glint_images.md#glint-contract).
  d.fields = {{"world_pos", "vec3", 0},   {"uv", "vec2", 3},
              {"J", "vec4", 5},           {"n", "vec3", 9},
              {"t", "vec3", 12},          {"b", "vec3", 15},
              {"view", "vec3", 18},       {"light", "vec3", 21},
              {"h", "vec3", 24},          {"pixel", "uvec2", 27},
              {"frame", "uint", 29},      {"seed", "uint", 30},
              {"light_kind", "uint", 31}, {"light_radiance", "float", 32},
              {"light_size", "vec2", 33}, {"light_edge", "vec3", 35}};
  d.helpers =
      "void glintlab_store(uint o, float v) { glintlab_out[o] = v; glintlab_out[o + 1u] = v; "
      "glintlab_out[o + 2u] = v; glintlab_out[o + 3u] = 1.0; }\n"
      "void glintlab_store(uint o, vec3 v) { glintlab_out[o] = v.x; glintlab_out[o + 1u] = v.y; "
      "glintlab_out[o + 2u] = v.z; glintlab_out[o + 3u] = 3.0; }\n";
  d.call = "  glintlab_store(i * glintlab_push.out_stride, $0(g));\n";
  d.signature = "float $0(GlintInput g) or vec3 $0(GlintInput g)";
  d.entries = {entry};
  return d;
}

// The fragment mode: the row's fields as locals named glintlab_<field> read for the quad's row (i >> 2),
// each lane's inputs moved by its offset, the user's globals assigned (`assign`), the user's main called
// and lane 0's `output` stored.
WrapperDeclaration fragment_wrapper(const std::string& assign, const std::string& output) {
  WrapperDeclaration d;
  d.header = "glintlab_fragment";
  d.push = {"in_stride", "out_stride", "pad"};
  d.buffers = {{0, "glintlab_in", "GlintlabIn", "uint", false}, {3, "glintlab_out", "GlintlabOut", "float", true}};
  constexpr int kDifferentials = static_cast<int>(kMethodInputWords);  // they follow GlintInput's words
  const auto word = [](int w) {
    return "glintlab_in[(i >> 2u) * glintlab_push.in_stride + " + std::to_string(w) + "u]";
  };
  const auto floats = [&](const std::string& type, int first, int n) {
    std::string e = n == 1 ? "" : type + "(";
    for (int k = 0; k < n; ++k) e += (k ? ", " : "") + std::string("uintBitsToFloat(") + word(first + k) + ")";
    return n == 1 ? e : e + ")";
  };
  d.fields = {{"glintlab_p0", "vec3", floats("vec3", 0, 3)},
              {"glintlab_uv0", "vec2", floats("vec2", 3, 2)},
              {"glintlab_J", "vec4", floats("vec4", 5, 4)},
              {"glintlab_n0", "vec3", floats("vec3", 9, 3)},
              {"glintlab_t", "vec3", floats("vec3", 12, 3)},
              {"glintlab_b", "vec3", floats("vec3", 15, 3)},
              {"glintlab_view0", "vec3", floats("vec3", 18, 3)},
              {"glintlab_light", "vec3", floats("vec3", 21, 3)},
              {"glintlab_h", "vec3", floats("vec3", 24, 3)},
              {"glintlab_pixel0", "uvec2", "uvec2(" + word(27) + ", " + word(28) + ")"},
              {"glintlab_frame", "uint", word(29)},
              {"glintlab_seed", "uint", word(30)},
              {"glintlab_dpdx", "vec3", floats("vec3", kDifferentials, 3)},
              {"glintlab_dpdy", "vec3", floats("vec3", kDifferentials + 3, 3)},
              {"glintlab_dndx", "vec3", floats("vec3", kDifferentials + 6, 3)},
              {"glintlab_dndy", "vec3", floats("vec3", kDifferentials + 9, 3)}};
  d.call =
      "  float glintlab_ox = float(i & 1u), glintlab_oy = float((i >> 1u) & 1u);\n"
      "  vec3 glintlab_world_pos = glintlab_p0 + glintlab_ox * glintlab_dpdx + glintlab_oy * glintlab_dpdy;\n"
      "  vec2 glintlab_uv = glintlab_uv0 + glintlab_ox * glintlab_J.xy + glintlab_oy * glintlab_J.zw;\n"
      "  vec3 glintlab_n = glintlab_n0 + glintlab_ox * glintlab_dndx + glintlab_oy * glintlab_dndy;\n"
      "  vec3 glintlab_view = glintlab_view0 - glintlab_ox * glintlab_dpdx - glintlab_oy * glintlab_dpdy;\n"
      "  uvec2 glintlab_pixel = glintlab_pixel0 + uvec2(i & 1u, (i >> 1u) & 1u);\n"
      "  glintlab_frag_coord = vec4(vec2(glintlab_pixel) + 0.5, 0.0, 1.0);\n" +
      assign +
      "\n  glintlab_fragment_main();\n"
      "  if ((i & 3u) == 0u) glintlab_store((i >> 2u) * glintlab_push.out_stride, vec3(" +
      output + "));\n";
  d.helpers =
      "void glintlab_store(uint o, vec3 v) { glintlab_out[o] = v.x; glintlab_out[o + 1u] = v.y; "
      "glintlab_out[o + 2u] = v.z; glintlab_out[o + 3u] = 3.0; }\n";
  d.signature = "void main() (a GLSL fragment shader)";
  d.entries = {"glintlab_fragment_main"};
  return d;
}

std::string fragment_wrapper_source(const std::string& assign, const std::string& output,
                                    const std::string& include_name) {
  return generate_wrapper(fragment_wrapper(assign, output), "glsl", include_name);
}

std::shared_ptr<Kernel> fragment_kernel(KernelSpec spec, const std::string& assign, const std::string& output) {
  if (spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'glsl' (the fragment mode reads GLSL)");
  spec.n_uniforms = 0;
  spec.vulkan_1_1 = true;
  return std::make_shared<Kernel>(spec, fragment_wrapper(assign, output));
}

void run_fragment(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s) {
  kernel.run_rows(in, kFragmentInputWords, count, out, kMethodOutputWords, timeout_s, 4);
}

std::string method_wrapper_source(const std::string& language, const std::string& entry,
                                  const std::string& include_name) {
  return generate_wrapper(method_wrapper(entry), language, include_name);
}

std::shared_ptr<Kernel> method_kernel(KernelSpec spec) {
  if (spec.language != "hlsl" && spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'hlsl' or 'glsl'");
  spec.n_uniforms = 0;
  return std::make_shared<Kernel>(spec, method_wrapper(spec.entry));
}

void run_method(const Kernel& kernel, const float* in, std::size_t count, float* out, double timeout_s) {
  kernel.run_rows(in, kMethodInputWords, count, out, kMethodOutputWords, timeout_s);
}

}  // namespace glintlab::shader
