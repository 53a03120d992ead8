// Counter-based RNG: known answers of Philox4x32-10, uniformity, and independence of neighbouring
// keys. Statistical checks use fixed seeds; each is a chi-square test at alpha = 1e-4 (a correct
// generator fails one of the five here with probability 5e-4 over the choice of seeds), and the last
// test shows the same check rejects a generator whose neighbouring keys are correlated.
#include <boost/math/distributions/chi_squared.hpp>
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "glintlab/base/rng.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/uniform_rows.hpp"

using glintlab::CounterRng;

namespace {

constexpr double kAlpha = 1e-4;

double chi2_pvalue(const std::vector<double>& counts, double expected_each) {
  double stat = 0;
  for (double c : counts) stat += (c - expected_each) * (c - expected_each) / expected_each;
  boost::math::chi_squared_distribution<double> d(static_cast<double>(counts.size() - 1));
  return boost::math::cdf(boost::math::complement(d, stat));
}

// 2-D chi-square on pairs (first(i), second(i)) over a bins x bins grid.
double pair_pvalue(const std::function<std::pair<double, double>(std::uint32_t)>& pair, int bins, std::uint32_t count) {
  std::vector<double> counts(static_cast<std::size_t>(bins * bins), 0.0);
  for (std::uint32_t i = 0; i < count; ++i) {
    auto [a, b] = pair(i);
    const int ia = static_cast<int>(a * bins), ib = static_cast<int>(b * bins);
    counts[static_cast<std::size_t>(ia * bins + ib)] += 1;
  }
  return chi2_pvalue(counts, static_cast<double>(count) / (bins * bins));
}

}  // namespace

TEST_CASE("Philox4x32-10 reproduces the Random123 known-answer vectors", "[rng]") {
  // tests/data/reference/philox4x32_10_kat.txt: counter[4] key[2] -> output[4], from Random123's kat_vectors.
  std::ifstream in(GLINTLAB_SOURCE_DIR "/tests/data/reference/philox4x32_10_kat.txt");
  REQUIRE(in.good());
  std::string line;
  int checked = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::array<std::uint32_t, 4> counter{}, want{};
    std::array<std::uint32_t, 2> key{};
    for (auto& c : counter) fields >> std::hex >> c;
    for (auto& k : key) fields >> std::hex >> k;
    for (auto& w : want) fields >> std::hex >> w;
    INFO("vector: " << line);
    CHECK(CounterRng::block(counter, key) == want);
    ++checked;
  }
  CHECK(checked == 3);
}

TEST_CASE("uniforms are a pure function of the key and lie in the open interval (0, 1)", "[rng]") {
  CounterRng a(42, 7, 9, 3, 1), b(42, 7, 9, 3, 1), c(42, 7, 9, 3, 2);
  bool all_equal_c = true;
  for (int i = 0; i < 1000; ++i) {
    const double x = a.uniform(), y = b.uniform(), z = c.uniform();
    REQUIRE(x == y);
    REQUIRE(x > 0.0);
    REQUIRE(x < 1.0);
    all_equal_c = all_equal_c && (x == z);
  }
  CHECK_FALSE(all_equal_c);
}

TEST_CASE("uniforms pass a 1000-bin chi-square uniformity test", "[rng][statistical]") {
  const int bins = 1000;
  const std::uint32_t count = 2'000'000;
  std::vector<double> counts(bins, 0.0);
  CounterRng rng(12345, 0, 0);
  for (std::uint32_t i = 0; i < count; ++i) counts[static_cast<std::size_t>(rng.uniform() * bins)] += 1;
  const double pv = chi2_pvalue(counts, count / double(bins));
  INFO("seed 12345, " << count << " draws, p-value " << pv);
  CHECK(pv > kAlpha);
}

TEST_CASE("neighbouring keys give independent numbers", "[rng][statistical]") {
  const std::uint32_t count = 1'000'000;
  const int bins = 32;
  SECTION("cell x and x + 1") {
    const double pv = pair_pvalue(
        [](std::uint32_t i) {
          CounterRng a(7, i, 0), b(7, i + 1, 0);
          return std::pair{a.uniform(), b.uniform()};
        },
        bins, count);
    INFO("p-value " << pv);
    CHECK(pv > kAlpha);
  }
  SECTION("seed s and s + 1") {
    const double pv = pair_pvalue(
        [](std::uint32_t i) {
          CounterRng a(1000, i, 5), b(1001, i, 5);
          return std::pair{a.uniform(), b.uniform()};
        },
        bins, count);
    INFO("p-value " << pv);
    CHECK(pv > kAlpha);
  }
  SECTION("level and stream neighbours, and successive draws of one key") {
    const double pv_level = pair_pvalue(
        [](std::uint32_t i) {
          CounterRng a(3, i, 1, 4, 0), b(3, i, 1, 5, 0);
          return std::pair{a.uniform(), b.uniform()};
        },
        bins, count);
    const double pv_draws = pair_pvalue(
        [](std::uint32_t i) {
          CounterRng a(3, i, 2);
          const double u = a.uniform();
          return std::pair{u, a.uniform()};
        },
        bins, count);
    INFO("p-values " << pv_level << ", " << pv_draws);
    CHECK(pv_level > kAlpha);
    CHECK(pv_draws > kAlpha);
  }
}

TEST_CASE("the independence check rejects correlated neighbouring keys", "[rng][statistical][power]") {
  // A deliberately bad keyed generator: the number of key x + 1 is that of key x shifted by a small
  // amount (as a naive "seed + cell index" LCG would give). The pair test must reject it.
  const double pv = pair_pvalue(
      [](std::uint32_t i) {
        CounterRng a(7, i, 0);
        const double u = a.uniform();
        return std::pair{u, std::fmod(u + 0.01 * a.uniform(), 1.0)};
      },
      32, 1'000'000);
  INFO("p-value " << pv);
  CHECK(pv < 1e-12);
}

TEST_CASE("batch uniforms equal the scalar counter RNG draw for draw", "[rng]") {
  // fill_uniforms runs a vectorized Philox (AVX-512 or AVX2 where available) or a portable loop;
  // every level must reproduce CounterRng::for_index exactly, including batches that cross
  // x = 2^32 (row >> 32 = y). Levels above the CPU's fall back to the best it has.
  struct Restore {
    ~Restore() { glintlab::detail::set_simd_level(2); }
  } restore;
  for (int simd : {2, 1, 0})
    for (int k : {1, 2, 3, 5}) {
      glintlab::detail::set_simd_level(simd);
      INFO("level in effect " << glintlab::detail::simd_level());
      for (std::uint64_t start :
           {std::uint64_t{0}, std::uint64_t{4093}, (std::uint64_t{1} << 32) - 3, (std::uint64_t{1} << 32) - 20}) {
        const std::size_t count = 1001;
        std::vector<double> batch(count * static_cast<std::size_t>(k));
        glintlab::detail::philox_uniform_rows(77, glintlab::kStreamSample, start, count, k, batch.data());
        for (std::size_t r = 0; r < count; ++r) {
          auto rng = CounterRng::for_index(77, start + r, glintlab::kStreamSample);
          for (int j = 0; j < k; ++j) {
            const double want = rng.uniform();
            if (batch[r * k + j] != want) {
              INFO("simd " << simd << ", k = " << k << ", row " << start + r << ", column " << j);
              REQUIRE(batch[r * k + j] == want);
            }
          }
        }
      }
    }
}
