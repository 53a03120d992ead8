// The Vulkan compute runner of shader laws (validation/include/glintlab/validation/shader.hpp) on
// whatever device the loader offers (lavapipe here and in CI): exact outputs of a simple kernel, the
// float32 uniform rule, compile errors with file and line, the signature message, timeouts, threads,
// and a kind of kernel of the test's own, declared and generated in both languages.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "glintlab/base/float32.hpp"
#include "glintlab/validation/shader.hpp"

using namespace glintlab::shader;

namespace {

KernelSpec spec(std::string source, std::string language = "glsl") {
  KernelSpec s;
  s.source = std::move(source);
  s.source_name = "test_kernel." + language;
  s.language = language;
  s.n_uniforms = 2;
  return s;
}

bool have_device() { return !vulkan_devices().empty(); }

}  // namespace

TEST_CASE("shader runner: a kernel's outputs, broadcast and per row", "[shader]") {
  if (!have_device()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  const Kernel k(spec("float count(float n, float p, vec4 u) { return n * p + u.x + 4.0 * u.w; }"));
  CHECK(!k.device_name().empty());
  const std::vector<double> n{3.0, 5.0, 7.0}, p{0.5};
  const std::vector<double> u{0.25, 0.9, 0.75, 0.1, 1.0, 0.0};
  std::vector<float> out(3);
  k.run(n.data(), n.size(), p.data(), p.size(), u.data(), 3, out.data(), 10.0);
  for (std::size_t i = 0; i < 3; ++i)  // u.w is 0: unused uniforms
    CHECK(out[i] == static_cast<float>(n[i]) * 0.5f + glintlab::uniform_to_float(u[2 * i]));
  CHECK(glintlab::uniform_to_float(1.0) < 1.0f);
  CHECK(glintlab::uniform_to_float(0.0) > 0.0f);
}

TEST_CASE("shader runner: many rows over several submissions, from several threads", "[shader]") {
  if (!have_device()) return;
  const Kernel k(spec("float count(float n, float p, float4 u) { return n + u.y; }", "hlsl"));
  const std::size_t rows = (std::size_t{1} << 20) + 123;  // more than one submission
  std::vector<double> n(rows), u(2 * rows);
  for (std::size_t i = 0; i < rows; ++i) {
    n[i] = static_cast<double>(i % 1000);
    u[2 * i] = 0.5;
    u[2 * i + 1] = static_cast<double>(i % 7) / 8.0;
  }
  const double p = 0.5;
  auto check_rows = [&] {
    std::vector<float> out(rows);
    k.run(n.data(), rows, &p, 1, u.data(), rows, out.data(), 60.0);
    std::size_t bad = 0;
    for (std::size_t i = 0; i < rows; ++i)
      bad += out[i] != static_cast<float>(n[i]) + glintlab::uniform_to_float(u[2 * i + 1]);
    return bad;
  };
  std::vector<std::size_t> bad(3);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < 3; ++t) threads.emplace_back([&, t] { bad[t] = check_rows(); });
  for (auto& t : threads) t.join();
  CHECK(bad == std::vector<std::size_t>{0, 0, 0});
}

TEST_CASE("shader runner: compile errors name the file and line, a wrong signature shows the expected one",
          "[shader]") {
  if (!have_device()) return;
  auto message = [](const KernelSpec& s) {
    try {
      Kernel k(s);
    } catch (const std::invalid_argument& e) { return std::string(e.what()); }
    return std::string("no error");
  };
  const std::string syntax = message(spec("float count(float n, float p, vec4 u) {\n  return n *;\n}\n"));
  CHECK(syntax.find("test_kernel.glsl:2: error") != std::string::npos);
  const std::string signature = message(spec("float count(float n, float p) { return n; }", "hlsl"));
  CHECK(signature.find("float count(float n, float p, float4 u)") != std::string::npos);
  KernelSpec bad = spec("float count(float n, float p, vec4 u) { return n; }");
  bad.language = "cuda";
  CHECK(message(bad).find("language = 'cuda'") != std::string::npos);
  bad = spec("float count(float n, float p, vec4 u) { return n; }");
  bad.n_uniforms = 5;
  CHECK(message(bad).find("n_uniforms = 5") != std::string::npos);
}

TEST_CASE("shader runner: a kernel past its timeout throws, and the device serves the next call", "[shader]") {
  if (!have_device()) return;
  const Kernel slow(
      spec("float count(float n, float p, vec4 u) { float a = u.x;\n"
           "  for (int i = 0; i < int(n); ++i) a = sin(a * 1.0001 + float(i) * 1e-7 + p);\n  return a; }"));
  // The fast kernel is compiled before the slow one runs: compiling it after (seconds in a Debug
  // ASan build) let the slow kernel finish first on a fast CPU, and the device was no longer busy.
  const Kernel fast(spec("float count(float n, float p, vec4 u) { return n; }"));
  const std::size_t rows = 5000;
  std::vector<double> u(2 * rows, 0.5);
  std::vector<float> out(rows);
  const double n = 60000, p = 0.5;
  CHECK_THROWS_AS(slow.run(&n, 1, &p, 1, u.data(), rows, out.data(), 0.05), ShaderTimeout);
  float one = 0;
  // Behind the slow kernel, a short timeout says the device is busy (this kernel never ran).
  CHECK_THROWS_AS(fast.run(&n, 1, &p, 1, u.data(), 1, &one, 0.001), ShaderDeviceBusy);
  fast.run(&n, 1, &p, 1, u.data(), 1, &one, 60.0);
  CHECK(one == 60000.0f);
}

namespace {
std::string error_of(const KernelSpec& s) {
  try {
    Kernel k(s);
  } catch (const std::invalid_argument& e) { return e.what(); }
  return "no error";
}
std::string error_of(const KernelSpec& s, const WrapperDeclaration& kind) {
  try {
    Kernel k(s, kind);
  } catch (const std::invalid_argument& e) { return e.what(); }
  return "no error";
}
}  // namespace

TEST_CASE("shader runner: the user's resources move to set 1 and run only once bound", "[shader]") {
  if (!have_device()) return;
  // Descriptor set 1 crashed lavapipe inside vkCreateComputePipelines / the dispatch when the pipeline
  // layout lacked it; now the user's resources are reflected, moved to set 1 and bound by name.
  Kernel set1(
      spec("layout(std430, set = 1, binding = 3) readonly buffer Extra { float extra[]; };\n"
           "float count(float n, float p, vec4 u) { return extra[1] * n; }"));
  REQUIRE(set1.declared_resources().size() == 1);
  CHECK(set1.declared_resources()[0].name == "Extra");
  CHECK(set1.declared_resources()[0].kind == "storage buffer");
  CHECK(set1.declared_resources()[0].size == 4);
  const double n = 3, p = 0.5;
  std::vector<double> u{0.5, 0.5};
  float out = 0;
  try {
    set1.run(&n, 1, &p, 1, u.data(), 1, &out, 60.0);
    FAIL("a kernel with an unbound resource ran");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("'Extra' (storage buffer) is declared but no data is bound") != std::string::npos);
  }
  ResourceData extra;
  extra.name = "Extra";
  float values[2] = {0.25f, 7.0f};
  std::uint32_t words[2];
  std::memcpy(words, values, sizeof words);
  extra.levels = {{words[0], words[1]}};
  set1.bind_resources({extra});
  set1.run(&n, 1, &p, 1, u.data(), 1, &out, 60.0);
  CHECK(out == 21.0f);
  ResourceData other = extra;
  other.name = "Other";
  CHECK_THROWS_WITH(set1.bind_resources({extra, other}),
                    Catch::Contains("'Other' is given but the shader does not declare it"));
  // A cbuffer is a uniform buffer with its members' names and offsets.
  Kernel cbuffer(
      spec("cbuffer Params : register(b0) { float scale; float3 tint; };\nfloat count(float n, float p, float4 u) { "
           "return scale; }",
           "hlsl"));
  REQUIRE(cbuffer.declared_resources().size() == 1);
  const auto& block = cbuffer.declared_resources()[0];
  CHECK((block.kind == "uniform buffer" && block.members.size() == 2));
  CHECK((block.members[1].name == "tint" && block.members[1].offset >= 4 && block.members[1].components == 3));
  // A storage image is not read-only: refused by name before the driver sees it.
  CHECK(error_of(spec("layout(r32f) uniform image2D img;\n"
                      "float count(float n, float p, vec4 u) { return imageLoad(img, ivec2(0)).r; }"))
            .find("'img' (image) is not bound by glintlab: a storage image") != std::string::npos);
  // The wrapper's own resources are exactly the allowed ones.
  for (const std::string language : {"glsl", "hlsl"}) {
    const Kernel ok(spec(language == "glsl" ? "float count(float n, float p, vec4 u) { return n * p + u.x; }"
                                            : "float count(float n, float p, float4 u) { return n * p + u.x; }",
                         language));
    const auto resources = spirv_resources(ok.spirv());
    CHECK(resources.size() == 5);
    for (const auto& r : resources)
      CHECK(
          (r.kind == "push constant" || (r.kind == "storage buffer" && r.set == 0 && r.binding >= 0 && r.binding < 4)));
  }
}

TEST_CASE("shader runner: an #include cycle is refused naming it", "[shader]") {
  if (!have_device()) return;
  KernelSpec s = spec("#include \"a.h\"\nfloat count(float n, float p, vec4 u) { return n; }");
  // Recorded files serve the includes (no disk): a.h and b.h include each other.
  s.include_files = {{"a.h", "#pragma once\n#include \"b.h\"\n"}, {"b.h", "#pragma once\n#include \"a.h\"\n"}};
  const std::string msg = error_of(s);
  CHECK((msg.find("#include cycle a.h -> b.h -> a.h") != std::string::npos ||
         msg.find("#include cycle b.h -> a.h -> b.h") != std::string::npos));
  s.include_files = {{"a.h", "#ifndef A\n#define A\n#include \"b.h\"\n#endif\n"},
                     {"b.h", "#ifndef B\n#define B\n#include \"a.h\"\n#endif\n"}};
  CHECK(error_of(s) == "no error");  // guarded: a legitimate cycle
}

TEST_CASE("shader runner: loops whose trip count is not a small constant", "[shader]") {
  if (!have_device()) return;
  const Kernel data(
      spec("float count(float n, float p, vec4 u) { float k = 0.0;\n"
           "  for (int i = 0; i < int(n); ++i) k += 1.0; return k; }"));
  CHECK(data.unbounded_loops() == 1);
  const Kernel small(
      spec("float count(float n, float p, vec4 u) { float k = 0.0;\n"
           "  for (int i = 0; i < 5000; ++i) k += u.x * float(i); return k; }"));
  CHECK(small.unbounded_loops() == 0);
  const Kernel big(
      spec("float count(float n, float p, vec4 u) { float k = 0.0;\n"
           "  for (int i = 0; i < 70000; ++i) k += u.x * float(i); return k; }"));
  CHECK(big.unbounded_loops() == 1);
}

TEST_CASE("shader runner: a new kind is one declaration, in both languages", "[shader]") {
  if (!have_device()) return;
  // A kind of its own: rows of (vec2 a, uint k) in, one float out, entry float mix2(vec2 a, uint k).
  WrapperDeclaration kind;
  kind.push = {"in_stride", "out_stride", "pad"};
  kind.buffers = {{0, "glintlab_in", "GlintlabIn", "uint", false}, {3, "glintlab_out", "GlintlabOut", "float", true}};
  kind.fields = {{"a", "vec2", 0}, {"k", "uint", 2}};
  kind.call = "  glintlab_out[i * glintlab_push.out_stride] = $0(a, k);\n";
  kind.signature = "float $0(vec2 a, uint k)";
  kind.entries = {"mix2"};
  CHECK(wrapper_signature(kind, "hlsl") == "float mix2(float2 a, uint k)");
  CHECK(generate_wrapper(kind, "hlsl", "x.hlsl").find("float2 a = float2(asfloat(glintlab_in[b + 0u])") !=
        std::string::npos);
  const std::vector<float> in{1.5f, 2.0f, 0.0f, 0.25f, -4.0f, 0.0f};
  std::vector<float> words(in);
  std::uint32_t k0 = 3, k1 = 5;  // the integer words as they are
  std::memcpy(&words[2], &k0, sizeof k0);
  std::memcpy(&words[5], &k1, sizeof k1);
  for (const std::string language : {"glsl", "hlsl"}) {
    KernelSpec s = spec(language == "glsl" ? "float mix2(vec2 a, uint k) { return a.x * a.y + float(k); }"
                                           : "float mix2(float2 a, uint k) { return a.x * a.y + float(k); }",
                        language);
    s.entry = "mix2";
    s.n_uniforms = 0;
    const Kernel kernel(s, kind);
    // Its resources are the declaration's: the push constant and the two buffers.
    CHECK(spirv_resources(kernel.spirv()).size() == 3);
    std::vector<float> out(2);
    kernel.run_rows(words.data(), 3, 2, out.data(), 1, 10.0);
    CHECK(out[0] == 1.5f * 2.0f + 3.0f);
    CHECK(out[1] == 0.25f * -4.0f + 5.0f);
    // The signature the declaration words is the one a wrong entry is told.
    s.source = language == "glsl" ? "float mix2(vec2 a) { return a.x; }" : "float mix2(float2 a) { return a.x; }";
    CHECK(error_of(s, kind).find("with the expected signature " + wrapper_signature(kind, language)) !=
          std::string::npos);
  }
}
