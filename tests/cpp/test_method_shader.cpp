// Method shaders (validation/include/glintlab/validation/method_shader.hpp): the wrapper reads the
// GlintInput rows (kMethodInputWords words) in place, float and float3 results come back with their
// channel count, and a wrong signature names the expected one. On whatever Vulkan device the loader offers.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "glintlab/validation/method_shader.hpp"

using namespace glintlab::shader;

namespace {

KernelSpec method_spec(std::string source, std::string language) {
  KernelSpec s;
  s.source = std::move(source);
  s.source_name = "test_method." + language;
  s.entry = "glint";
  s.language = language;
  s.include_dirs = {std::string(GLINTLAB_SOURCE_DIR) + "/python/glintlab/data/shaders"};
  return s;
}

std::uint32_t bits(float x) {
  std::uint32_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
}

}  // namespace

TEST_CASE("method shaders: the GlintInput fields arrive in place, float and float3 results", "[shader][method]") {
  if (vulkan_devices().empty()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  const std::size_t rows = 5;
  std::vector<std::uint32_t> in(rows * kMethodInputWords);
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::size_t w = 0; w < 27; ++w)
      in[i * kMethodInputWords + w] = bits(static_cast<float>(i) + 0.01f * static_cast<float>(w));
    in[i * kMethodInputWords + 27] = static_cast<std::uint32_t>(10 + i);  // pixel column
    in[i * kMethodInputWords + 28] = 7;                                   // pixel row
    in[i * kMethodInputWords + 29] = 3;                                   // frame
    in[i * kMethodInputWords + 30] = 123456789;                           // seed
    in[i * kMethodInputWords + 31] = 2;                                   // light_kind: a rectangle
    for (std::size_t w = 32; w < kMethodInputWords; ++w)                  // light_radiance, light_size, light_edge
      in[i * kMethodInputWords + w] = bits(static_cast<float>(i) + 0.01f * static_cast<float>(w));
  }
  std::vector<float> out(rows * kMethodOutputWords);
  SECTION("glsl, vec3") {
    auto k =
        method_kernel(method_spec("vec3 glint(GlintInput g) { return vec3(g.J.w, g.h.z, float(g.pixel.x) + "
                                  "float(g.frame) + float(g.seed % 1000u)); }",
                                  "glsl"));
    run_method(*k, reinterpret_cast<const float*>(in.data()), rows, out.data(), 10.0);
    for (std::size_t i = 0; i < rows; ++i) {
      const float* o = &out[i * kMethodOutputWords];
      CHECK(o[0] == static_cast<float>(i) + 0.01f * 8.0f);   // J.w: word 8
      CHECK(o[1] == static_cast<float>(i) + 0.01f * 26.0f);  // h.z: word 26
      CHECK(o[2] == static_cast<float>(10 + i + 3 + 789));
      CHECK(o[3] == 3.0f);
    }
  }
  SECTION("hlsl, float") {
    auto k = method_kernel(method_spec("float glint(GlintInput g) { return g.view.y + float(g.pixel.y); }", "hlsl"));
    run_method(*k, reinterpret_cast<const float*>(in.data()), rows, out.data(), 10.0);
    for (std::size_t i = 0; i < rows; ++i) {
      const float* o = &out[i * kMethodOutputWords];
      CHECK(o[0] == (static_cast<float>(i) + 0.01f * 19.0f) + 7.0f);  // view.y: word 19
      CHECK(o[1] == o[0]);
      CHECK(o[3] == 1.0f);
    }
  }
  SECTION("glsl, the light's extent") {
    auto k =
        method_kernel(method_spec("vec3 glint(GlintInput g) { return vec3(float(g.light_kind) + g.light_radiance, "
                                  "g.light_size.y, g.light_edge.z); }",
                                  "glsl"));
    run_method(*k, reinterpret_cast<const float*>(in.data()), rows, out.data(), 10.0);
    for (std::size_t i = 0; i < rows; ++i) {
      const float* o = &out[i * kMethodOutputWords];
      CHECK(o[0] == 2.0f + (static_cast<float>(i) + 0.01f * 32.0f));  // light_kind + light_radiance: words 31, 32
      CHECK(o[1] == static_cast<float>(i) + 0.01f * 34.0f);           // light_size.y: word 34
      CHECK(o[2] == static_cast<float>(i) + 0.01f * 37.0f);           // light_edge.z: word 37
    }
  }
  SECTION("a wrong signature names the contract") {
    try {
      method_kernel(method_spec("float glint(float x) { return x; }", "glsl"));
      FAIL("compiled");
    } catch (const std::invalid_argument& e) {
      CHECK(std::string(e.what()).find("float glint(GlintInput g) or vec3 glint(GlintInput g)") != std::string::npos);
    }
  }
}
