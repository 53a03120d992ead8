// The mollified roulette's fast paths (core/blends/roulette.cpp): its closed-form moments against
// Gauss-Kronrod quadrature, and its batch forms (combine_rows, combine_rows_each, with their vector
// kernels at every SIMD level) against combine() per row, bit for bit.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <vector>

#include "glintlab/base/rng.hpp"
#include "glintlab/counting/blend.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/roulette.hpp"
#include "glintlab/detail/uniform_rows.hpp"
#include "glintlab/stats/normal.hpp"

using namespace glintlab;

namespace {

using Moments = std::function<std::array<double, 2>(double, double)>;

// The weights of the comparison at one eps: a grid of step 1/2000 plus the breakpoints of R's pieces
// (0, eps, 2 eps, 1 - 2 eps, 1 - eps, 1) and their neighbouring doubles.
std::vector<double> test_weights(double eps) {
  std::vector<double> w;
  for (int i = 0; i <= 2000; ++i) w.push_back(i / 2000.0);
  for (double c :
       {0.0, eps, 2 * eps, 3 * eps, 0.5 * eps, 0.5, 1 - 3 * eps, 1 - 2 * eps, 1 - eps, 1.0, 1e-300, 1e-12, 1e-320}) {
    for (double x : {c, std::nextafter(c, -1.0), std::nextafter(c, 2.0)})
      if (x >= 0 && x <= 1) w.push_back(x);
  }
  return w;
}

std::vector<double> test_epsilons() {
  // Tiny ones too: w / 2eps then overflows its fifth power (1e-70) or 1 / 2eps itself (subnormals).
  std::vector<double> e = {1e-9, 1e-6,  1e-3,   0.01,   0.1,    0.25,  0.49, std::nextafter(0.5, 0.0),
                           0.5,  1e-70, 1e-200, 1e-300, 1e-310, 5e-324};
  for (int i = 1; i <= 40; ++i) e.push_back(i / 80.0);
  return e;
}

// The largest absolute difference of either moment from the quadrature over the test grid.
double largest_difference(const Moments& moments) {
  double worst = 0;
  for (double eps : test_epsilons())
    for (double w : test_weights(eps)) {
      const auto a = moments(w, eps), q = blend_detail::roulette_moments_quadrature(w, eps);
      worst = std::max({worst, std::abs(a[0] - q[0]), std::abs(a[1] - q[1])});
    }
  return worst;
}

}  // namespace

TEST_CASE("the roulette's closed-form moments agree with quadrature", "[blend][roulette]") {
  // Largest difference measured: 9.9e-16 (eps and weight over the grid above). A tolerance of 4e-15:
  // about 20 ulps of 1, far below any missing or wrong piece (each is at least ~1e-4 somewhere).
  constexpr double kTolerance = 4e-15;
  const double worst = largest_difference(blend_detail::roulette_moments);
  INFO("largest |closed form - quadrature| = " << worst);
  CHECK(worst <= kTolerance);
  // The ends exactly: R is 0 (1) for every r at weight 0 (1), so the sums' variance is exactly 0.
  for (double eps : test_epsilons()) {
    CHECK(blend_detail::roulette_moments(0.0, eps) == std::array<double, 2>{0.0, 0.0});
    CHECK(blend_detail::roulette_moments(1.0, eps) == std::array<double, 2>{1.0, 1.0});
  }
  // The two levels' means add up to 1 at every weight (E[R(r, w)] + E[R(r, 1 - w)] = 1).
  for (double eps : test_epsilons())
    for (double w : test_weights(eps))
      CHECK(blend_detail::roulette_moments(w, eps)[0] + blend_detail::roulette_moments(1 - w, eps)[0] ==
            Approx(1.0).margin(1e-15));
  // An eps below half an ulp of r leaves R no window: the step, never 0 / 0.
  CHECK(blend_detail::roulette_keep(0.5, 0.5, 5e-324) == 0.0);
  CHECK(blend_detail::roulette_keep(0.5, std::nextafter(0.5, 1.0), 5e-324) == 1.0);
  // The comparison catches a closed form with a piece missing (each of the three in turn).
  for (int dropped = 0; dropped < 3; ++dropped) {
    const double wrong = largest_difference([dropped](double w, double eps) {
      if (!(w > 0)) return std::array<double, 2>{0.0, 0.0};
      if (!(w < 1)) return std::array<double, 2>{1.0, 1.0};
      const auto p = blend_detail::roulette_moment_pieces(w, blend_detail::RouletteEps(eps));
      std::array<double, 2> m = {0.0, 0.0};
      for (int i = 0; i < 3; ++i)
        if (i != dropped)
          for (int j = 0; j < 2; ++j) m[j] += p[i][j];
      return m;
    });
    INFO("piece " << dropped << " dropped: largest difference " << wrong);
    CHECK(wrong > 1e3 * kTolerance);
  }
}

namespace {

struct SimdGuard {
  ~SimdGuard() { detail::set_simd_level(2); }
};

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// Uniforms for the rows' first blocks: Philox draws, with AS 241's region boundaries (1/2 +- 0.425),
// the far tails and 1/2 itself planted among them (and their neighbouring doubles).
std::vector<double> first_blocks(std::uint64_t seed, std::size_t rows) {
  std::vector<double> u(2 * rows);
  fill_uniforms(seed, kStreamSample, 0, rows, 2, u.data());
  const double planted[] = {0.075, 0.925, 0.5, 1e-300, 1e-20, 1 - 1e-16, 0.0, 1.0};
  std::size_t at = 0;
  for (double x : planted)
    for (double v : {x, std::nextafter(x, 0.0), std::nextafter(x, 1.0)}) {
      u[2 * at] = v;
      at += 7;
    }
  return u;
}

}  // namespace

TEST_CASE("the roulette's combine_rows and combine_rows_each are combine() per row, bit for bit", "[blend][roulette]") {
  SimdGuard guard;
  // A base area that is not a power of 2: P / A_l then rounds, so the order of operations shows.
  const LevelLadder ladder(4, 1.3);
  const std::size_t m = 1500;  // several of the rule's row blocks
  std::vector<double> w(m);
  fill_uniforms(3, kStreamSample, 0, m, 1, w.data());
  // Footprints over three levels, some at a level's area (w = 0: the upper weight 0, R = 0).
  std::vector<double> area(m);
  std::vector<LevelBracket> brackets(m);
  for (std::size_t r = 0; r < m; ++r) {
    area[r] = r % 11 == 0 ? ladder.area(static_cast<int>(r % 3)) : 1.3 * std::exp(std::log(64.0) * w[r]);
    brackets[r] = ladder.bracket(area[r]);
  }
  // Counts on every path: none, explicit facets (whole and fractional), the normal sum.
  const double counts[] = {0.0, 3.0, 40.5, 64.0, 64.5, 65.0, 400.0, 400.25, 2.5e3, 1e5, 7e2, 1.2e3};
  std::vector<double> k_lo(m), k_hi(m);
  // Rows 512-1023 (the rule's third and fourth blocks of 256) only empty levels and normal sums.
  const double normal_counts[] = {0.0, 65.0, 400.0, 400.25, 2.5e3, 1e5, 7e2};
  for (std::size_t r = 0; r < m; ++r) {
    const bool normal_only = r >= 512 && r < 1024;
    k_lo[r] = normal_only ? normal_counts[(r * 5) % 7] : counts[(r * 5) % 12];
    k_hi[r] = normal_only ? normal_counts[(r * 3 + 1) % 7] : counts[(r * 7 + 3) % 12];
  }
  const std::array<std::vector<double>, 2> first = {first_blocks(1, m), first_blocks(2, m)};
  for (double eps : {0.1, 0.0, 1e-3, 0.3, 0.5}) {
    const auto rule = make_blend("roulette", {{"epsilon", eps}});
    for (const bool with_first : {true, false}) {
      // Row r's level-j stream: its first block from `first` (as the drivers' prefetched blocks),
      // then Philox.
      const auto stream = [&](std::size_t r, int j) {
        const CounterRng rng(9, static_cast<std::uint32_t>(r), 0, static_cast<std::uint16_t>(brackets[r].lo + j),
                             kStreamLevelFacets);
        return with_first ? FacetStream(first[static_cast<std::size_t>(j)].data() + 2 * r, rng) : FacetStream(rng);
      };
      BlendRule::FacetRows rows;
      if (with_first) rows.first = {first[0].data(), first[1].data()};
      rows.stream = stream;
      std::vector<double> expected(m), each(m);
      for (std::size_t r = 0; r < m; ++r) {
        std::array<FacetStream, 2> streams = {stream(r, 0), stream(r, 1)};
        expected[r] = rule->combine(area[r], brackets[r], k_lo[r], k_hi[r], streams);
      }
      // One bracket for every row (brackets[1]: not at a level's area).
      std::vector<double> one_expected(m), one(m);
      const auto one_stream = [&](std::size_t r, int j) {
        const CounterRng rng(9, static_cast<std::uint32_t>(r), 0, static_cast<std::uint16_t>(brackets[1].lo + j),
                             kStreamLevelFacets);
        return with_first ? FacetStream(first[static_cast<std::size_t>(j)].data() + 2 * r, rng) : FacetStream(rng);
      };
      BlendRule::FacetRows one_rows = rows;
      one_rows.stream = one_stream;
      for (std::size_t r = 0; r < m; ++r) {
        std::array<FacetStream, 2> streams = {one_stream(r, 0), one_stream(r, 1)};
        one_expected[r] = rule->combine(area[1], brackets[1], k_lo[r], k_hi[r], streams);
      }
      for (int level : {2, 1, 0}) {
        detail::set_simd_level(level);
        rule->combine_rows_each(area.data(), brackets.data(), m, k_lo.data(), k_hi.data(), rows, each.data());
        rule->combine_rows(area[1], brackets[1], m, k_lo.data(), k_hi.data(), one_rows, one.data());
        INFO("eps " << eps << " first blocks " << with_first << " simd " << level);
        CHECK(same_bits(each, expected));
        CHECK(same_bits(one, one_expected));
      }
    }
  }
}

TEST_CASE("the vector central quantile is normal::quantile bit for bit (AS 241's central region)",
          "[roulette][normal]") {
  SimdGuard guard;
  // Philox uniforms, then sweeps of consecutive doubles across the region's ends 1/2 -+ 0.425 and
  // around 1/2, and the ends of (0, 1).
  std::vector<double> u(200000);
  fill_uniforms(8, kStreamSample, 0, u.size(), 1, u.data());
  for (double c : {0.075, 0.925, 0.5, 0.0, 1.0}) {
    double below = c, above = c;
    for (int i = 0; i < 2000; ++i) {
      below = std::nextafter(below, -1.0);
      above = std::nextafter(above, 2.0);
      u.push_back(below);
      u.push_back(above);
    }
    u.push_back(c);
  }
  std::vector<double> expected(u.size());
  std::size_t central = 0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    const bool is_central = std::abs(u[i] - 0.5) <= 0.425;
    central += is_central;
    expected[i] = is_central ? normal::quantile(u[i]) : std::numeric_limits<double>::quiet_NaN();
  }
  // Both region ends were crossed: central and tail values on either side of each.
  REQUIRE(central > 100000);
  REQUIRE(central < u.size() - 8000);
  const auto same = [](const std::vector<double>& a, const std::vector<double>& b) {
    for (std::size_t i = 0; i < a.size(); ++i) {
      const bool both_nan = std::isnan(a[i]) && std::isnan(b[i]);
      if (!both_nan && std::memcmp(&a[i], &b[i], sizeof(double)) != 0) return false;
    }
    return true;
  };
  for (int level : {2, 1, 0}) {
    detail::set_simd_level(level);
    std::vector<double> got(u.size());
    detail::normal_quantile_central(u.data(), u.size(), got.data());
    INFO("simd level " << level);
    CHECK(same(got, expected));
  }
  // The whole quantile given its logarithm from std::log: the same bits everywhere, the tails (and
  // the far tails, r > 5) included. A logarithm one ulp off (a vector log's error) shows.
  std::vector<double> all = u;
  for (double x : {1e-12, 1e-20, 1e-100, 1e-300, 5e-324, 1 - 1e-12, 1 - 1e-16, 0.0, 1.0, -0.5, 1.5}) all.push_back(x);
  std::vector<double> exact(all.size()), lt(all.size()), lt_off(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    exact[i] = normal::quantile(all[i]);
    lt[i] = std::log(all[i] - 0.5 < 0.0 ? all[i] : 1.0 - all[i]);
    lt_off[i] = std::nextafter(lt[i], 0.0);
  }
  for (int level : {2, 1, 0}) {
    detail::set_simd_level(level);
    std::vector<double> got(all.size()), off(all.size());
    detail::normal_quantile_with_log(all.data(), lt.data(), all.size(), got.data());
    detail::normal_quantile_with_log(all.data(), lt_off.data(), all.size(), off.data());
    INFO("simd level " << level);
    CHECK(same(got, exact));
    CHECK_FALSE(same(off, exact));
  }
  // The comparison sees a single rounding: the same rational function with its Horner steps fused
  // (what FMA contraction would compile) differs from normal::quantile on some of these uniforms.
  std::vector<double> fused(u.size());
  const auto horner_fma = [](const double(&c)[8], double x) {
    double s = c[7];
    for (int i = 6; i >= 0; --i) s = std::fma(s, x, c[i]);
    return s;
  };
  for (std::size_t i = 0; i < u.size(); ++i) {
    const double q = u[i] - 0.5, r = 0.180625 - q * q;
    fused[i] = std::abs(q) <= 0.425 ? q * horner_fma(normal::detail::kA, r) / horner_fma(normal::detail::kB, r)
                                    : std::numeric_limits<double>::quiet_NaN();
  }
  CHECK_FALSE(same(fused, expected));
}
