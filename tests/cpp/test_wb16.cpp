// WB16's C++ twin in the core: the hashed noise is a wrapped trilinear texture (texel centres give the
// texel's value, one period later the same), the cell values are uniform-looking in [0, 1), bad switches
// are refused, and the result does not depend on the thread count. Its agreement with the shader,
// pixel by pixel, is tested in tests/python/test_method_shaders.py (it needs Vulkan).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/glinty/wb16.hpp"

using namespace glintlab;

TEST_CASE("wb16 noise: texel centres, wrap, values from 0 up to 1", "[wb16]") {
  const int cells[4][3] = {{3, 5, 7}, {0, 0, 0}, {127, 1, 64}, {-1, 2, 3}};
  for (const auto& c : cells) {
    float want[3], got[3], wrapped[3];
    wb16::cell_values(c[0] & 127, c[1] & 127, c[2] & 127, 9u, want);
    const float p[3] = {(static_cast<float>(c[0]) + 0.5f) / 128.0f, (static_cast<float>(c[1]) + 0.5f) / 128.0f,
                        (static_cast<float>(c[2]) + 0.5f) / 128.0f};
    const float q[3] = {p[0] + 1.0f, p[1] + 1.0f, p[2] + 1.0f};
    wb16::noise3(p, 9u, got);
    wb16::noise3(q, 9u, wrapped);
    for (int j = 0; j < 3; ++j) {
      CHECK(got[j] == Approx(want[j]).margin(1e-6));
      CHECK(wrapped[j] == Approx(want[j]).margin(2e-5));
    }
  }
  double sum = 0;
  float lo = 1, hi = 0, v[3];
  for (int i = 0; i < 20000; ++i) {
    wb16::cell_values(i % 128, (i / 128) % 128, i / 16384, 0u, v);
    for (float x : v) {
      sum += x;
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  }
  CHECK(lo >= 0.0f);
  CHECK(hi < 1.0f);
  CHECK(std::abs(sum / 60000 - 0.5) < 0.01);
}

TEST_CASE("wb16 twin: deterministic across threads, bad switches refused", "[wb16]") {
  // Rows of a plane seen from a camera: world_pos on z = 0, n = +z, view towards (0, -2, 1).
  const std::size_t m = 40000;
  std::vector<std::uint32_t> rows(m * wb16::kInputWords, 0u);
  auto put = [&](std::size_t i, int k, float f) { std::memcpy(&rows[i * wb16::kInputWords + k], &f, sizeof f); };
  for (std::size_t i = 0; i < m; ++i) {
    const float x = -1.0f + 2.0f * static_cast<float>(i % 200) / 200.0f, y = static_cast<float>(i / 200) / 100.0f;
    put(i, 0, x);
    put(i, 1, y);
    put(i, 11, 1.0f);
    put(i, 18, -x);
    put(i, 19, -2.0f - y);
    put(i, 20, 1.0f);
    rows[i * wb16::kInputWords + 30] = 3u;
  }
  wb16::Params prm;
  std::vector<float> a(m), b(m), pos(3 * m);
  const int threads = num_threads();
  set_num_threads(1);
  wb16::twin(rows.data(), m, prm, a.data(), pos.data());
  set_num_threads(4);
  wb16::twin(rows.data(), m, prm, b.data(), nullptr);
  set_num_threads(threads);
  CHECK(std::memcmp(a.data(), b.data(), m * sizeof(float)) == 0);
  std::size_t lit = 0;
  for (float x : a) {
    REQUIRE(x >= 0.0f);
    REQUIRE(x <= 1.0f);
    lit += x > 0.0f;
  }
  // Sparkles: some pixels lit, most not (the kernel covers a small share of each cell).
  CHECK(lit > m / 100);
  CHECK(lit < m / 2);
  prm.shape = 2;
  CHECK_THROWS_AS(wb16::twin(rows.data(), m, prm, a.data(), nullptr), std::invalid_argument);
}
