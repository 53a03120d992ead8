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
