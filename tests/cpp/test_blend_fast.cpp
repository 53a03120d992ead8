// The blends' fast paths against their general paths, bit for bit: the inner laws' fixed evaluators
// (one (n, p), many rows: gated's StepInversion, binomial's QuantileTable) against evaluate(); the
// ladder's bisection against its logarithm; and whole blends (every rule, gated / binomial / head_cf
// inside, one P, runs of equal P, P per sample, sample and sample_at, 1 and 2 threads, every SIMD
// level) against the same blend driven through evaluate() alone (no fixed evaluator, no per-pixel path).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "glintlab/counting/blend.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"

using namespace glintlab;

namespace {

// Uniforms as the blends draw them (fill_uniforms rows), plus, for one-uniform laws, the values where
// binomial::quantile's decision flips: u at cdf(k), 1 - sf(k) and their neighbours, the clamps' ends.
std::vector<double> test_uniforms(const CountingLaw& law, double n, double p, std::size_t rows) {
  const int k = law.n_uniforms();
  std::vector<double> u(rows * static_cast<std::size_t>(k));
  fill_uniforms(17, kStreamSample, 0, rows, k, u.data());
  if (k == 1 && law.name() == "binomial" && p > 0) {
    const double mean = n * p, sd = std::sqrt(std::max(n * p * (1 - p), 0.25));
    const double stride = std::max(1.0, std::floor(sd / 8));  // about 150 counts across the window
    for (double kk = std::max(0.0, std::floor(mean - 9 * sd)); kk <= std::min(std::ceil(n), mean + 9 * sd);
         kk += stride) {
      for (double v : {binomial::cdf(kk, n, p), 1.0 - binomial::sf(kk, n, p)}) {
        if (!(v > 0 && v < 1)) continue;
        u.push_back(v);
        u.push_back(std::nextafter(v, 0.0));
        u.push_back(std::nextafter(v, 1.0));
      }
    }
    for (double v : {0.0, 1e-300, 0x1p-53, 0x1p-54, 0.5, std::nextafter(0.5, 0.0), std::nextafter(0.5, 1.0),
                     1.0 - 0x1p-53, std::nextafter(1.0, 0.0), 1.0})
      u.push_back(v);
  }
  return u;
}

InnerLaw evaluate_only(const std::string& name) {
  // The general path, obviously correct: evaluate() row by row, no fixed evaluator, no per-pixel code.
  std::shared_ptr<const CountingLaw> law(make_law(name));
  InnerLaw inner = InnerLaw::from_law(law);
  const CountingLaw* raw = law.get();
  const auto k = static_cast<std::size_t>(raw->n_uniforms());
  inner.evaluate = [raw, k](const double* n, const double* p, const double* u, std::size_t m, double* out) {
    for (std::size_t i = 0; i < m; ++i) out[i] = raw->evaluate(n[i], p[i], u + i * k);
  };
  inner.fixed_evaluator = nullptr;
  return inner;
}

struct SimdLevelGuard {
  ~SimdLevelGuard() { detail::set_simd_level(2); }
};
struct ThreadsGuard {
  int saved = num_threads();
  ~ThreadsGuard() { set_num_threads(saved); }
};

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST_CASE("fixed evaluators give evaluate()'s bits at every (n, p) and SIMD level", "[blend][fast]") {
  SimdLevelGuard guard;
  const std::vector<std::array<double, 2>> points = {
      {4e4, 0.01}, {1.6e5, 0.01}, {16, 0.1},   {37.3, 0.3},  {1e3, 0.5}, {1e3, 0.97}, {2.5, 0.999}, {0.4, 0.2},
      {1e6, 0.3},  {1e7, 0.01},   {1e9, 1e-6}, {123.7, 1.0}, {55, 0.0},  {0, 0.3},    {1e4, 1e-9},  {7, 0.5}};
  for (const char* name : {"gated", "binomial", "head_cf"}) {
    const auto law = make_law(name);
    for (const auto& [n, p] : points) {
      for (std::size_t rows : {std::size_t{50}, std::size_t{3000}, std::size_t{200000}}) {
        if (!law->accepts(n, p)) continue;
        const auto u = test_uniforms(*law, n, p, std::min<std::size_t>(rows, 4000));
        const std::size_t k = static_cast<std::size_t>(law->n_uniforms()), m = u.size() / k;
        std::vector<double> expected(m);
        for (std::size_t r = 0; r < m; ++r) expected[r] = law->evaluate(n, p, u.data() + r * k);
        const auto fixed = detail::KernelOf(*law)->fixed_evaluator(n, p, rows);
        for (int level : {2, 1, 0}) {
          detail::set_simd_level(level);
          std::vector<double> got(m, -1.0);
          fixed->evaluate(u.data(), m, got.data());
          INFO(name << " n " << n << " p " << p << " rows " << rows << " simd " << level);
          CHECK(same_bits(got, expected));
        }
      }
    }
  }
}

TEST_CASE("the binomial's quantile table tabulates where it pays and answers as quantile", "[blend][fast]") {
  CHECK(binomial::QuantileTable(4e4, 0.01, 1000000).tabulated());
  CHECK(!binomial::QuantileTable(4e4, 0.01, 100).tabulated());  // the window would cost more than it saves
  CHECK(!binomial::QuantileTable(10, 0.0, 1000000).tabulated());
  const binomial::QuantileTable table(1e3, 0.3, 1000000);
  for (double u = 1e-6; u < 1; u += 0.0137) CHECK(table(u) == binomial::quantile(u, 1e3, 0.3));
}

TEST_CASE("the ladder's bisection finds the logarithm's level", "[blend][fast]") {
  for (double ratio : {4.0, 2.0, 1.5, 10.0}) {
    for (double base : {1.0, 16.0 / 4096, 3.7}) {
      const LevelLadder ladder(ratio, base);
      std::vector<double> areas(4000);
      fill_uniforms(3, kStreamSample, 0, areas.size(), 1, areas.data());
      for (double& a : areas) a = base * std::pow(ratio, 600 * (a - 0.5));  // inside and outside the table
      for (int l = -300; l <= 300; l += 7) {
        areas.push_back(ladder.area(l));
        areas.push_back(std::nextafter(ladder.area(l), 0.0));
        areas.push_back(std::nextafter(ladder.area(l), INFINITY));
      }
      for (double a : areas) {
        // The reference: the logarithm's guess settled by steps (the ladder's path outside its table).
        int lo = static_cast<int>(std::floor(std::log(a / base) / std::log(ratio)));
        while (ladder.area(lo) > a) --lo;
        while (ladder.area(lo + 1) <= a) ++lo;
        const LevelBracket b = ladder.bracket(a);
        INFO("ratio " << ratio << " base " << base << " P " << a);
        CHECK(b.lo == lo);
        CHECK(b.area_lo == ladder.area(lo));
        CHECK(b.area_hi == ladder.area(lo + 1));
        CHECK(b.w_lod == std::clamp(std::log(a / b.area_lo) / std::log(ratio), 0.0, std::nextafter(1.0, 0.0)));
      }
    }
  }
}

TEST_CASE("blends' fast paths reproduce the general path bit for bit", "[blend][fast]") {
  SimdLevelGuard simd_guard;
  ThreadsGuard threads_guard;
  const std::size_t count = 3000;
  std::vector<double> random_P(count), runs_P(count), ps(count), xs(count), ys(count), w(count);
  fill_uniforms(5, kStreamSample, 0, count, 1, w.data());
  for (std::size_t i = 0; i < count; ++i) {
    random_P[i] = std::exp(std::log(16.0) * w[i]);
    runs_P[i] = std::exp(std::log(64.0) * w[i / 1100 * 1100]);  // runs of 1100 equal areas, across chunks
    ps[i] = 0.001 + 0.4 * w[(i * 7) % count];
    xs[i] = 3 * w[(i * 11) % count];
    ys[i] = 3 * w[(i * 13) % count];
  }
  const std::vector<std::pair<std::string, LawParams>> rules = {
      {"distributed", {}}, {"zk16_linear", {}}, {"nearest", {}}, {"roulette", {}}, {"roulette", {{"epsilon", 0.0}}}};
  for (const auto& [rule, params] : rules) {
    for (const char* inner : {"gated", "binomial", "head_cf"}) {
      const BlendedLaw fast(make_blend(rule, params),
                            InnerLaw::from_law(std::shared_ptr<const CountingLaw>(make_law(inner))), LevelLadder(4, 1));
      const BlendedLaw general(make_blend(rule, params), evaluate_only(inner), LevelLadder(4, 1));
      // The general path of the exact binomial is CDF inversion per draw (microseconds): fewer draws.
      const std::size_t n_draws = std::string(inner) == "binomial" ? 1000 : count;
      struct Case {
        double N;
        ParamArray P, p;
      };
      const double one_P[] = {4.0, 5.5, 15.99, 0.3};
      const double one_p[] = {0.01, 0.3};
      std::vector<Case> cases;
      for (const double& P : one_P)
        for (const double& p : one_p) cases.push_back({1e4, {&P, 1}, {&p, 1}});
      cases.push_back({1e4, {random_P.data(), n_draws}, {&one_p[0], 1}});
      cases.push_back({123.7, {random_P.data(), n_draws}, {ps.data(), n_draws}});
      cases.push_back({1e4, {runs_P.data(), n_draws}, {&one_p[0], 1}});
      cases.push_back({2e3, {runs_P.data(), n_draws}, {ps.data(), n_draws}});
      // Both thread counts at the highest SIMD level, the lower levels on one thread.
      for (const auto& [level, threads] : {std::pair{2, 1}, std::pair{2, 2}, std::pair{1, 1}, std::pair{0, 1}}) {
        if (level < 2 && std::string(inner) == "binomial") continue;  // its fast path has no vector code
        detail::set_simd_level(level);
        {
          set_num_threads(threads);
          for (std::size_t c = 0; c < cases.size(); ++c) {
            const Case& cs = cases[c];
            const std::size_t m = n_draws;
            std::vector<double> a(m), b(m), at_a(m), at_b(m);
            fast.sample(cs.N, cs.P, cs.p, m, 11 + c, a.data());
            general.sample(cs.N, cs.P, cs.p, m, 11 + c, b.data());
            fast.sample_at(cs.N, cs.P, cs.p, {xs.data(), m}, {ys.data(), m}, m, 3, at_a.data());
            general.sample_at(cs.N, cs.P, cs.p, {xs.data(), m}, {ys.data(), m}, m, 3, at_b.data());
            INFO(rule << " eps " << (params.empty() ? "default" : "0") << " [" << inner << "] case " << c << " simd "
                      << level << " threads " << threads);
            CHECK(same_bits(a, b));
            CHECK(same_bits(at_a, at_b));
          }
        }
      }
    }
  }
}

TEST_CASE("a bad element of a long array is named, the lowest index first, on any number of threads", "[blend][fast]") {
  ThreadsGuard threads_guard;
  const BlendedLaw law(make_blend("distributed"),
                       InnerLaw::from_law(std::shared_ptr<const CountingLaw>(make_law("gated"))), LevelLadder(4, 1));
  std::vector<double> P(20000, 2.0), out(P.size());
  const double p = 0.1;
  P[17000] = 1e300;  // beyond the 16-bit level index
  P[9000] = 1e200;
  for (int threads : {1, 2}) {
    set_num_threads(threads);
    CHECK_THROWS_WITH(law.sample(10, {P.data(), P.size()}, {&p, 1}, P.size(), 1, out.data()),
                      Catch::Contains("(P = 9.9999999999999997e+199)"));
  }
}

TEST_CASE("a facet stream with its first block from the vectorized rows draws as the scalar stream", "[blend][fast]") {
  SimdLevelGuard guard;
  for (int level : {2, 1, 0}) {
    detail::set_simd_level(level);
    const std::size_t start = (std::size_t{1} << 32) - 5, rows = 40;  // rows across the cell's y = 1 boundary
    for (int lod : {-3, 0, 2}) {
      const auto key = static_cast<std::uint16_t>(static_cast<std::int16_t>(lod));
      std::vector<double> first(rows * 2);
      detail::philox_uniform_rows_level(9, key, kStreamLevelFacets, start, rows, 2, first.data());
      for (std::size_t r = 0; r < rows; ++r) {
        const std::size_t i = start + r;
        const CounterRng rng(9, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(i >> 32), key,
                             kStreamLevelFacets);
        FacetStream prefetched(first.data() + 2 * r, rng);
        CounterRng scalar = rng;
        for (int d = 0; d < 7; ++d) CHECK(prefetched.uniform() == scalar.uniform());
      }
    }
  }
}

TEST_CASE("the roulette keeps nothing of the upper level at w = 0, so it need not be drawn", "[blend][fast]") {
  // trials() gives the upper level no trials when P is a level's area: combine() of any upper count
  // at w = 0 must equal combine() of none, bit for bit (hard and mollified roulette, every facet path).
  const LevelLadder ladder(4, 1);
  const LevelBracket b = ladder.bracket(16.0);
  REQUIRE(b.w_lod == 0.0);
  for (double eps : {0.0, 0.1, 0.3}) {
    const auto rule = make_blend("roulette", {{"epsilon", eps}});
    CHECK(rule->trials(1e3, 16.0, b)[1] == 0.0);
    CHECK(rule->trials(1e3, 16.0, b)[0] == 1.6e4);
    for (double k_lo : {0.0, 3.0, 40.5, 500.0, 1e5})
      for (double k_hi : {1.0, 7.25, 64.0, 65.0, 3e4}) {
        for (std::uint32_t cell = 0; cell < 50; ++cell) {
          std::array<FacetStream, 2> a = {FacetStream(CounterRng(1, cell, 0, 2, kStreamLevelFacets)),
                                          FacetStream(CounterRng(1, cell, 0, 3, kStreamLevelFacets))};
          std::array<FacetStream, 2> c = a;
          const double with = rule->combine(16.0, b, k_lo, k_hi, a), without = rule->combine(16.0, b, k_lo, 0.0, c);
          INFO("eps " << eps << " k_lo " << k_lo << " k_hi " << k_hi << " cell " << cell);
          CHECK(std::memcmp(&with, &without, sizeof with) == 0);
        }
      }
  }
}

TEST_CASE("LevelLadder::brackets gives bracket()'s bits for every row, at every SIMD level", "[blend][fast]") {
  // The vector passes (level guess, two steps, weights) and the rows they leave to bracket():
  // areas inside and outside the tabulated levels, on a level's area and one ulp either side, and
  // ratios near 1 where the guess is more than one level off.
  SimdLevelGuard guard;
  std::vector<double> areas;
  std::uint64_t state = 7;
  auto uniform = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1p-53;
  };
  for (int i = 0; i < 3000; ++i) areas.push_back(std::exp(-700.0 + 1400.0 * uniform()));  // far outside too
  for (int i = 0; i < 3000; ++i) areas.push_back(std::exp(-5.0 + 10.0 * uniform()));
  for (double ratio : {4.0, 2.0, 1.5, 1.01, 10.0}) {
    for (double base : {1.0, 0.3, 1e-3}) {
      const LevelLadder ladder(ratio, base);
      std::vector<double> a = areas;
      for (int l = -300; l <= 300; l += 7)
        for (double v : {ladder.area(l), std::nextafter(ladder.area(l), 0.0), std::nextafter(ladder.area(l), 1e308)})
          if (v > 0 && std::isfinite(v)) a.push_back(v);
      // Keep the level index within 16 bits (bracket() refuses the rest, tested elsewhere).
      std::erase_if(a, [&](double v) { return !(std::abs(std::log(v / base) / std::log(ratio)) < 30000); });
      for (int level : {0, 1, 2}) {
        detail::set_simd_level(level);
        std::vector<LevelBracket> got(a.size());
        ladder.brackets(a.data(), a.size(), got.data());
        std::size_t differ = 0;
        for (std::size_t r = 0; r < a.size(); ++r) {
          const LevelBracket want = ladder.bracket(a[r]);
          differ += want.lo != got[r].lo || std::memcmp(&want.area_lo, &got[r].area_lo, sizeof(double)) != 0 ||
                    std::memcmp(&want.area_hi, &got[r].area_hi, sizeof(double)) != 0 ||
                    std::memcmp(&want.w_lod, &got[r].w_lod, sizeof(double)) != 0 ||
                    std::memcmp(&want.w_area, &got[r].w_area, sizeof(double)) != 0;
        }
        // Without the fractional LOD (rules that weigh by area): the same but w_lod, which is NaN.
        std::vector<LevelBracket> no_lod(a.size());
        ladder.brackets_without_lod(a.data(), a.size(), no_lod.data());
        std::size_t differ_no_lod = 0;
        for (std::size_t r = 0; r < a.size(); ++r)
          differ_no_lod += no_lod[r].lo != got[r].lo || no_lod[r].area_lo != got[r].area_lo ||
                           no_lod[r].area_hi != got[r].area_hi || !(no_lod[r].w_area == got[r].w_area) ||
                           !std::isnan(no_lod[r].w_lod);
        INFO("ratio " << ratio << " base " << base << " simd " << level);
        CHECK(differ == 0);
        CHECK(differ_no_lod == 0);
      }
    }
  }
}

TEST_CASE("a blend with P per sample stops at its lowest refused sample, earlier chunks drawn", "[blend][fast]") {
  // The checks are fused into the draws: the error names the lowest bad sample whatever the thread
  // count, and samples of chunks before it are drawn (the documented partial output).
  ThreadsGuard threads_guard;
  const BlendedLaw law(make_blend("zk16_linear"),
                       InnerLaw::from_law(std::shared_ptr<const CountingLaw>(make_law("gated"))), LevelLadder(4, 1));
  std::vector<double> P(50000, 3.0), p(P.size(), 0.1);
  P[41000] = -1.0;
  p[30000] = 1.5;
  for (int threads : {1, 2}) {
    set_num_threads(threads);
    std::vector<double> out(P.size(), -7.0);
    CHECK_THROWS_WITH(law.sample(1e3, {P.data(), P.size()}, {p.data(), p.size()}, P.size(), 1, out.data()),
                      Catch::Contains("p[30000] = 1.5"));
    CHECK(out[0] != -7.0);      // the first chunk is drawn (it precedes the refused sample)
    CHECK(out[30000] == -7.0);  // the refused sample's chunk is not
  }
}
