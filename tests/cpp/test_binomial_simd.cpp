// The exact binomial's vector paths (Sampler::sample_rows, binomial::sample_pixels: BTRD's step 1
// and the inversion's first steps across samples) must give, bit for bit, the scalar Sampler's draw
// on each sample's own generator, at every SIMD level.
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"

using namespace glintlab;

namespace {

// The general path: one scalar Sampler draw on CounterRng::for_index (no prefetching, no vectors).
double scalar_draw(double n, double p, std::uint64_t seed, std::uint64_t index) {
  auto rng = CounterRng::for_index(seed, index, kStreamSample);
  return binomial::Sampler(n, p)(rng);
}

std::size_t count_mismatches(const std::vector<double>& got, const std::vector<double>& want) {
  std::size_t bad = 0;
  for (std::size_t i = 0; i < got.size(); ++i)
    bad += !(got[i] == want[i] && std::signbit(got[i]) == std::signbit(want[i]));
  return bad;
}

struct RestoreSimd {
  ~RestoreSimd() {
    detail::set_simd_level(2);
    set_num_threads(2);
  }
};

}  // namespace

TEST_CASE("vector BTRD step 1 across a batch equals the scalar sampler, bit for bit", "[binomial][simd]") {
  // BTRD's regime from its threshold (mean 30) to n = 2^53, integer and fractional n, p on both
  // sides of 1/2; the inversion and constant regimes go through the same entry point.
  const std::vector<std::pair<double, double>> points{
      {1e6, 0.3},          {1e9, 1e-6}, {60, 0.5},      {61, 0.49},    {59.5, 0.5},      {62.5, 0.51},
      {1e6 + 0.5, 0.3},    {1e15, 0.5}, {9e15, 0.25},   {1e12, 0.999}, {1e4 + 0.7, 0.9}, {3000, 0.01},
      {1e9 + 0.999, 1e-6}, {16, 0.1},   {2999.9, 0.01}, {100, 0},      {100, 1},         {0.5, 0.5}};
  const std::size_t count = 3000, first = 4294967000ull;  // crosses 2^32: the rows' high word changes
  RestoreSimd restore;
  const auto law = make_law("binomial");
  std::vector<double> got(count), want(count);
  for (int level : {2, 1, 0}) {
    detail::set_simd_level(level);
    for (const auto& [n, p] : points) {
      for (std::uint64_t seed : {1ull, 0xDEADBEEFCAFEull}) {
        detail::KernelOf(*law)->sample_range(n, p, seed, first, first + count, got.data());
        for (std::size_t i = 0; i < count; ++i) want[i] = scalar_draw(n, p, seed, first + i);
        INFO("n = " << n << ", p = " << p << ", seed " << seed << ", SIMD level " << detail::simd_level());
        CHECK(count_mismatches(got, want) == 0);
      }
    }
  }
}

TEST_CASE("vector per-pixel setup and first steps equal the scalar sampler, bit for bit", "[binomial][simd][pixels]") {
  // Pixels over every regime: log-uniform n in [0, 1e15] (integer and fractional), p log-uniform
  // towards 0 and towards 1 and uniform, plus edge values; through sample_many at 1 and 2 threads
  // and through the law's sample_pixels at an odd start.
  const std::size_t count = 100'000;
  std::vector<double> n(count), p(count), got(count), want(count);
  CounterRng pick(3, 4, 5);
  const double edge_n[] = {0, 0.3, 1, 1.5, 2, 3, 16, 1e15, 60, 59.5, 61, 9e15};
  const double edge_p[] = {0, 0.5, 1, 1e-300, 0.4999999999, 0.5000000001, 1e-15, 1 - 1e-15};
  for (std::size_t i = 0; i < count; ++i) {
    const double a = pick.uniform(), b = pick.uniform(), c = pick.uniform();
    n[i] = i % 17 == 0 ? edge_n[(i / 17) % 12] : std::exp(a * std::log(1e15));
    if (i % 3 == 1) n[i] = std::floor(n[i]);
    p[i] = i % 13 == 0 ? edge_p[(i / 13) % 8]
                       : (i % 2 ? std::exp(std::log(1e-12) * b) : 1 - std::exp(std::log(1e-12) * b));
    if (i % 5 == 0) p[i] = c;
  }
  RestoreSimd restore;
  const auto law = make_law("binomial");
  for (int level : {2, 1, 0}) {
    detail::set_simd_level(level);
    for (std::size_t i = 0; i < count; ++i) want[i] = scalar_draw(n[i], p[i], 11, i);
    for (int threads : {1, 2}) {
      set_num_threads(threads);
      sample_many(*law, {n.data(), count}, {p.data(), count}, count, 11, got.data());
      INFO("sample_many, " << threads << " threads, SIMD level " << detail::simd_level());
      CHECK(count_mismatches(got, want) == 0);
    }
    const std::size_t start = 4294967001ull, m = 1000;
    std::vector<double> g(m), w(m);
    detail::KernelOf(*law)->sample_pixels(n.data(), p.data(), 11, start, m, g.data());
    for (std::size_t i = 0; i < m; ++i) w[i] = scalar_draw(n[i], p[i], 11, start + i);
    INFO("sample_pixels at start " << start << ", SIMD level " << detail::simd_level());
    CHECK(count_mismatches(g, w) == 0);
  }
}

TEST_CASE("the per-pixel path reports bad parameters as the scalar sampler does", "[binomial][simd][errors]") {
  const auto law = make_law("binomial");
  const double n[] = {10, 10, 10}, p_bad[] = {0.5, 1.5, 0.5}, n_bad[] = {10, NAN, 10}, p[] = {0.5, 0.5, 0.5};
  double out[3];
  CHECK_THROWS_WITH(detail::KernelOf(*law)->sample_pixels(n, p_bad, 1, 0, 3, out), Catch::Contains("p = 1.5"));
  CHECK_THROWS_AS(detail::KernelOf(*law)->sample_pixels(n_bad, p, 1, 0, 3, out), std::invalid_argument);
}

TEST_CASE("tabulated BTRD final-test values give the same draws", "[binomial][determinism]") {
  // Long batches tabulate log f(k) - log f(mode) around the mode (Sampler::tabulate_log_ratios): the
  // same values, so the same draws, including those whose k falls outside the table.
  for (auto [n, p] : {std::pair{1e9, 1e-6}, {3000.0, 0.01}, {1e6, 0.3}, {100.0, 0.5}, {61.5, 0.7}}) {
    binomial::Sampler plain(n, p, true), table(n, p, true);
    table.tabulate_log_ratios(1'000'000);
    for (std::uint64_t i = 0; i < 200'000; ++i) {
      auto r1 = CounterRng::for_index(5, i, kStreamSample), r2 = r1;
      const double a = plain(r1), b = table(r2);
      if (a != b) {
        INFO("n = " << n << ", p = " << p << ", seed 5, index " << i << ": " << a << " vs " << b);
        REQUIRE(a == b);
      }
    }
  }
}
