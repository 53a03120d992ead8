// Device timings of the runner's dispatches (glintlab/validation/dispatch_timing.hpp): whose dispatches a
// DispatchTiming records (its thread's, the innermost scope's), one entry per dispatch, and none without one.
#include <catch2/catch.hpp>

#include <thread>
#include <vector>

#include "glintlab/validation/dispatch_timing.hpp"
#include "glintlab/validation/shader.hpp"

using namespace glintlab::shader;

namespace {

Kernel law_kernel() {
  KernelSpec s;
  s.source = "float count(float n, float p, vec4 u) { return n * p + u.x; }";
  s.source_name = "timing_kernel.glsl";
  s.language = "glsl";
  s.n_uniforms = 1;
  return Kernel(s);
}

void run(const Kernel& k, std::size_t rows) {
  const std::vector<double> n{3.0}, p{0.5}, u(rows, 0.25);
  std::vector<float> out(rows);
  k.run(n.data(), 1, p.data(), 1, u.data(), rows, out.data(), 30.0);
}

}  // namespace

TEST_CASE("dispatch timing: one entry per dispatch, in the innermost scope of the calling thread", "[shader]") {
  if (vulkan_devices().empty()) {
    WARN("no Vulkan device: install mesa-vulkan-drivers");
    return;
  }
  const Kernel k = law_kernel();
  run(k, 10);  // no scope: nothing recorded, nothing refused
  DispatchTiming outer;
  run(k, (std::size_t{1} << 20) + 5);  // two submissions of the law path
  REQUIRE(outer.milliseconds().size() == 2);
  for (double ms : outer.milliseconds()) CHECK(ms >= 0.0);
  {
    DispatchTiming inner;
    run(k, 10);
    CHECK(inner.milliseconds().size() == 1);
    CHECK(outer.milliseconds().size() == 2);  // the inner scope took it
  }
  std::thread other([&] { run(k, 10); });  // another thread's dispatch: not this thread's scope
  other.join();
  CHECK(outer.milliseconds().size() == 2);
  run(k, 10);
  CHECK(outer.milliseconds().size() == 3);
}
