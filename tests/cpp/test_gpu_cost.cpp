// The GPU compiler statistics (validation/include/glintlab/validation/gpu_cost.hpp): RADV null devices
// compile a law kernel per architecture at its wave size, report ACO's statistics and ISA, and refuse an
// unknown architecture or non-SPIR-V input by name. Skipped (with a warning) where RADV is missing.
#include <catch2/catch.hpp>

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "glintlab/validation/gpu_cost.hpp"
#include "glintlab/validation/shader.hpp"

using namespace glintlab;

namespace {

std::vector<std::uint32_t> law_spirv(const std::string& body) {
  shader::KernelSpec s;
  s.source = body;
  s.source_name = "gpu_cost_test.glsl";
  s.language = "glsl";
  s.n_uniforms = 2;
  return shader::compile_spirv(s, shader::wrapper_source("glsl", "count", s.source_name), "main");
}

bool have_radv() { return gpu_cost::driver_status().error.empty(); }

std::map<std::string, double> stats_of(const gpu_cost::PipelineStats& s) {
  return {s.statistics.begin(), s.statistics.end()};
}

}  // namespace

TEST_CASE("gpu_cost: statistics per architecture at its wave size, and the ISA", "[gpu_cost]") {
  if (!have_radv()) {
    WARN("RADV missing: install mesa-vulkan-drivers (" + gpu_cost::driver_status().error + ")");
    return;
  }
  const auto spirv = law_spirv("float count(float n, float p, vec4 u) { return sin(n * p) + u.x; }");
  const auto rdna = gpu_cost::compile_stats(spirv, "navi21", true);
  const auto gcn = gpu_cost::compile_stats(spirv, "polaris10");
  CHECK(rdna.subgroup_size == 32);
  CHECK(gcn.subgroup_size == 64);
  CHECK(rdna.device_name.find("NAVI21") != std::string::npos);
  CHECK(rdna.driver.rfind("radv", 0) == 0);
  for (const char* name : {"Instructions", "VGPRs", "SGPRs", "Spilled VGPRs", "Subgroups per SIMD", "Latency",
                           "Inverse Throughput", "Code size"}) {
    CHECK(stats_of(rdna).count(name) == 1);
    CHECK(stats_of(gcn).count(name) == 1);
  }
  CHECK(stats_of(rdna)["Instructions"] > 5);
  bool has_isa = false;
  for (const auto& [name, text] : rdna.representations)
    has_isa = has_isa || (name == "Assembly" && text.find("v_sin_f32") != std::string::npos);
  CHECK(has_isa);
  // A heavier function costs more cycles on the same architecture.
  const auto heavy = gpu_cost::compile_stats(
      law_spirv("float count(float n, float p, vec4 u) { return sin(n * p) * cos(u.x) + exp(u.y) * log(n + 2.0); }"),
      "navi21");
  CHECK(stats_of(heavy)["Latency"] > stats_of(rdna)["Latency"]);
}

TEST_CASE("gpu_cost: an unknown architecture and non-SPIR-V input are refused by name", "[gpu_cost]") {
  if (!have_radv()) return;
  const auto known = gpu_cost::known_architectures();
  REQUIRE(known.size() >= 3);
  CHECK_THROWS_WITH(gpu_cost::compile_stats(law_spirv("float count(float n, float p, vec4 u) { return n; }"), "navi99"),
                    Catch::Contains("unknown architecture 'navi99'") && Catch::Contains("gfx1100"));
  CHECK_THROWS_AS(gpu_cost::compile_stats({1u, 2u, 3u, 4u, 5u}, "navi21"), std::invalid_argument);
}
