// Shader samplers (validation/include/glintlab/validation/sampler_shader.hpp): the wrapper reads the
// 16-word rows in place and calls sample_h or pdf_h by the mode word, in both languages; a missing or
// mistyped function names the contract's signatures; the shipped GGX VNDF body's pdf_h is the visible-
// normal density computed here in double. On whatever Vulkan device the loader offers.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "glintlab/validation/sampler_shader.hpp"

using namespace glintlab::shader;

namespace {

KernelSpec sampler_spec(std::string source, std::string language) {
  KernelSpec s;
  s.source = std::move(source);
  s.source_name = "test_sampler." + language;
  s.entry = "sample_h";
  s.language = language;
  s.include_dirs = {std::string(GLINTLAB_SOURCE_DIR) + "/python/glintlab/data/shaders"};
  return s;
}

void put(std::vector<float>& in, std::size_t row, std::size_t word, float x) {
  in[row * kSamplerInputWords + word] = x;
}

void put_mode(std::vector<float>& in, std::size_t row, std::uint32_t mode) {
  std::memcpy(&in[row * kSamplerInputWords + 9], &mode, sizeof mode);
}

}  // namespace

TEST_CASE("shader samplers: rows arrive in place, the mode word picks the function", "[shader][sampler-shader]") {
  if (vulkan_devices().empty()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  const std::string language = GENERATE(std::string("hlsl"), std::string("glsl"));
  const std::string v = language == "hlsl" ? "float" : "vec";
  // sample_h echoes uv.y, J.w, wo.z and u.w; pdf_h returns h.x + 10 h.y + 100 h.z + J.x.
  const std::string code = v + "4 sample_h(" + v + "2 uv, " + v + "4 J, " + v + "3 wo, " + v + "4 u) { return " + v +
                           "4(uv.y, J.w, wo.z, u.w); }\nfloat pdf_h(" + v + "2 uv, " + v + "4 J, " + v + "3 wo, " + v +
                           "3 h) { return h.x + 10.0 * h.y + 100.0 * h.z + J.x; }\n";
  auto k = sampler_kernel(sampler_spec(code, language));
  const std::size_t rows = 4;
  std::vector<float> in(rows * kSamplerInputWords, 0.0f), out(rows * kSamplerOutputWords, -1.0f);
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::size_t w = 0; w < 9; ++w) put(in, i, w, static_cast<float>(i) + 0.01f * static_cast<float>(w));
    for (std::size_t w = 10; w < 14; ++w) put(in, i, w, 0.1f * static_cast<float>(w - 9));
    put_mode(in, i, static_cast<std::uint32_t>(i % 2));
  }
  run_sampler(*k, in.data(), rows, out.data(), 10.0);
  for (std::size_t i = 0; i < rows; ++i) {
    const float* o = &out[i * kSamplerOutputWords];
    const float f = static_cast<float>(i);
    if (i % 2 == 0) {
      CHECK(o[0] == f + 0.01f);      // uv.y: word 1
      CHECK(o[1] == f + 0.01f * 5);  // J.w: word 5
      CHECK(o[2] == f + 0.01f * 8);  // wo.z: word 8
      CHECK(o[3] == 0.4f);           // u.w: word 13
    } else {
      CHECK(o[0] == Approx(0.1 + 10 * 0.2 + 100 * 0.3 + (f + 0.02)).epsilon(1e-6));
      CHECK(o[1] == 0.0f);
      CHECK(o[3] == 0.0f);
    }
  }
}

TEST_CASE("shader samplers: a missing pdf_h names the contract", "[shader][sampler-shader]") {
  if (vulkan_devices().empty()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  try {
    sampler_kernel(sampler_spec("float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return u; }", "hlsl"));
    FAIL("compiled without pdf_h");
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    CHECK(msg.find("float pdf_h(float2 uv, float4 J, float3 wo, float3 h)") != std::string::npos);
    CHECK(msg.find("pdf_h") != std::string::npos);
  }
  CHECK_THROWS_AS(
      sampler_kernel(sampler_spec("float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return u; }", "hlsl"),
                     "1bad"),
      std::invalid_argument);
}

TEST_CASE("shader samplers: the shipped GGX VNDF pdf_h is the visible-normal density", "[shader][sampler-shader]") {
  if (vulkan_devices().empty()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  auto k = sampler_kernel(
      sampler_spec("#define GLINTLAB_GLSL\n#include \"glintlab_prelude.h\"\n#include \"ggx_vndf_body.h\"\n", "glsl"));
  const double a = 0.3, wo[3] = {0.6, 0.0, 0.8};
  const std::size_t rows = 64;
  std::vector<float> in(rows * kSamplerInputWords, 0.0f), out(rows * kSamplerOutputWords);
  std::vector<double> want(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    const double th = 1.5 * static_cast<double>(i) / rows, ph = 0.7 * static_cast<double>(i);
    const float h[3] = {static_cast<float>(std::sin(th) * std::cos(ph)),
                        static_cast<float>(std::sin(th) * std::sin(ph)), static_cast<float>(std::cos(th))};
    for (int j = 0; j < 3; ++j) {
      put(in, i, 6 + j, static_cast<float>(wo[j]));
      put(in, i, 10 + j, h[j]);
    }
    put_mode(in, i, 1u);
    // G1(wo) max(0, wo.h) D(h) / wo.z in double, at the float32 h the shader sees.
    const double hx = h[0], hy = h[1], hz = h[2];
    const double c2 = hz * hz, t2 = (hx * hx + hy * hy) / c2;
    const double D = 1.0 / (M_PI * a * a * c2 * c2 * (1 + t2 / (a * a)) * (1 + t2 / (a * a)));
    const double tan2o = (wo[0] * wo[0] + wo[1] * wo[1]) / (wo[2] * wo[2]);
    const double G1 = 2.0 / (1.0 + std::sqrt(1.0 + a * a * tan2o));
    want[i] = G1 * std::max(0.0, wo[0] * hx + wo[1] * hy + wo[2] * hz) * D / wo[2];
  }
  run_sampler(*k, in.data(), rows, out.data(), 10.0);
  for (std::size_t i = 0; i < rows; ++i)
    CHECK(out[i * kSamplerOutputWords] == Approx(want[i]).epsilon(3e-5).margin(1e-6));
}

TEST_CASE("shader samplers: the contract on l, and the functions read from the preprocessed code",
          "[shader][sampler-shader]") {
  // The functions the code declares, its #includes and defines expanded (no device needed).
  const std::string shipped =
      "#define GLINTLAB_HLSL\n#include \"glintlab_prelude.h\"\n#include \"ggx_vndf_l_body.h\"\n";
  CHECK(sampler_functions(sampler_spec(shipped, "hlsl")) == std::vector<std::string>{"sample_l", "pdf_l"});
  auto helpers = sampler_spec("#define GGX_VNDF_HELPERS_ONLY\n#include \"ggx_vndf_body.h\"\n", "hlsl");
  CHECK(sampler_functions(helpers).empty());
  helpers.defines = {{"EXTRA", "1"}};
  helpers.source +=
      "#ifdef EXTRA\nfloat pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return pdf_l(h); }\n#endif\n";
  CHECK(sampler_functions(helpers) == std::vector<std::string>{"pdf_h"});  // a call is no declaration
  CHECK(sampler_signature("glsl", "sample_l", "pdf_l", "l") ==
        "vec4 sample_l(vec2 uv, vec4 J, vec3 wo, vec4 u) and float pdf_l(vec2 uv, vec4 J, vec3 wo, vec3 l)");
  CHECK_THROWS_AS(sampler_signature("glsl", "sample_l", "pdf_l", "x"), std::invalid_argument);
  if (vulkan_devices().empty()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  // The l wrapper: mode 0 calls sample_l, mode 1 pdf_l with l read from words 10..12.
  auto spec = sampler_spec(
      "float4 sample_l(float2 uv, float4 J, float3 wo, float4 u) { return float4(u.x, wo.y, uv.x, J.z); }\n"
      "float pdf_l(float2 uv, float4 J, float3 wo, float3 l) { return l.x + 10.0 * l.y + 100.0 * l.z; }\n",
      "hlsl");
  spec.entry = "sample_l";
  auto k = sampler_kernel(spec, "pdf_l", "l");
  std::vector<float> in(2 * kSamplerInputWords, 0.0f), out(2 * kSamplerOutputWords, -1.0f);
  for (std::size_t i = 0; i < 2; ++i) {
    put(in, i, 0, 0.25f);
    put(in, i, 4, 0.5f);
    put(in, i, 7, 0.75f);
    for (std::size_t w = 10; w < 13; ++w) put(in, i, w, 0.1f * static_cast<float>(w - 9));
    put_mode(in, i, static_cast<std::uint32_t>(i));
  }
  run_sampler(*k, in.data(), 2, out.data(), 10.0);
  CHECK(out[0] == 0.1f);
  CHECK(out[1] == 0.75f);
  CHECK(out[2] == 0.25f);
  CHECK(out[3] == 0.5f);
  CHECK(out[kSamplerOutputWords] == Approx(0.1 + 10 * 0.2 + 100 * 0.3).epsilon(1e-6));
  // The h contract's function names do not meet the l contract.
  spec.entry = "sample_h";
  CHECK_THROWS_AS(sampler_kernel(spec, "pdf_h", "h"), std::invalid_argument);
}
