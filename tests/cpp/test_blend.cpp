// LOD blending: the level ladder, each blend's exact law against its sampler, DB23 eq. 10's
// equality with Binomial(N P, p), ZK16's variance deficit, the roulette's mean, coherence of
// positioned draws, thread independence and bad input.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <memory>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/blend.hpp"
#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/chi2.hpp"
#include "glintlab/stats/metrics.hpp"

using namespace glintlab;

namespace {

BlendedLaw blended(const std::string& name, const std::string& inner = "binomial", double ratio = 4, double base = 1.0,
                   LawParams params = {}) {
  return BlendedLaw(make_blend(name, params), InnerLaw::from_law(std::shared_ptr<const CountingLaw>(make_law(inner))),
                    LevelLadder(ratio, base));
}

std::vector<double> draw(const BlendedLaw& law, double N, double P, double p, std::size_t count, std::uint64_t seed) {
  std::vector<double> out(count);
  law.sample(N, {&P, 1}, {&p, 1}, count, seed, out.data());
  return out;
}

std::vector<double> rounded(std::vector<double> x) {
  for (double& v : x) v = std::floor(v + 0.5);
  return x;
}

double mean(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return s / static_cast<double>(x.size());
}

double variance(const std::vector<double>& x) {
  const double m = mean(x);
  double s = 0;
  for (double v : x) s += (v - m) * (v - m);
  return s / static_cast<double>(x.size() - 1);
}

// DB23 Fig. 4's setting: a grid of N = 64^2 cells, levels of 16 and 64 cells (ratio 4).
constexpr double kN = 4096, kALo = 16.0 / 4096;

}  // namespace

TEST_CASE("the ladder brackets every area exactly, for ratios 4 and 2", "[blend]") {
  for (double ratio : {4.0, 2.0}) {
    const LevelLadder ladder(ratio, 1.0);
    for (int l = -20; l <= 3; ++l) {
      const double a = ladder.area(l);
      const auto b = ladder.bracket(a);
      CHECK(b.lo == l);
      CHECK(b.w_lod == 0.0);
      CHECK(b.w_area == 0.0);
      const auto below = ladder.bracket(std::nextafter(a, 0.0));
      CHECK(below.lo == l - 1);
      CHECK(below.w_lod > 0.999);
      const auto mid = ladder.bracket(a * std::sqrt(ratio));
      CHECK(mid.lo == l);
      CHECK(mid.w_lod == Approx(0.5).epsilon(1e-12));
      CHECK(mid.w_area == Approx((std::sqrt(ratio) - 1) / (ratio - 1)).epsilon(1e-12));
    }
  }
  CHECK_THROWS_AS(LevelLadder(1.0, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(LevelLadder(NAN, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(LevelLadder(4.0, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(LevelLadder(4.0, 1.0).bracket(-1.0), std::invalid_argument);
  CHECK_THROWS_AS(LevelLadder(4.0, 1.0).bracket(NAN), std::invalid_argument);
  CHECK_THROWS_AS(LevelLadder(4.0, 1.0).bracket(INFINITY), std::invalid_argument);
  CHECK_THROWS_AS(LevelLadder(1.0001, 1.0).bracket(1e-300), std::invalid_argument);  // level beyond 16 bits
}

TEST_CASE("distributed equals Binomial(N P, p) when trial counts are integers (DB23 eq. 10)", "[blend]") {
  const auto law = blended("distributed", "binomial", 4, kALo);
  for (double cells : {16.0, 19.0, 28.0, 40.0, 52.0, 61.0, 64.0, 100.0}) {  // 64 (cells - 16) / 48 integer
    for (double p : {0.02, 0.3, 0.9}) {
      const Distribution d = law.pmf(kN, cells / kN, p);
      const Distribution ref = binomial::distribution(cells, p);
      INFO("cells " << cells << " p " << p);
      CHECK(distance(d, ref, Metric::kTV) < 1e-13);
    }
  }
}

TEST_CASE("distributed with non-integer trial counts: mean N P p, variance within p^2/2 of the binomial", "[blend]") {
  const auto law = blended("distributed", "binomial", 4, kALo);
  for (double cells : {17.3, 25.5, 40.01, 61.9}) {
    for (double p : {0.1, 0.7}) {
      const Distribution d = law.pmf(kN, cells / kN, p);
      const Distribution ref = binomial::distribution(cells, p);  // the stratified rule for N P
      INFO("cells " << cells << " p " << p);
      CHECK(d.mean() == Approx(cells * p).epsilon(1e-12));
      CHECK(d.var() >= ref.var() - 1e-12);
      CHECK(d.var() <= ref.var() + p * p / 2 + 1e-12);
    }
  }
}

TEST_CASE("every blend's sampler follows its exact law", "[blend][statistical]") {
  // 4 blends (roulette hard) x 2 inner laws x 3 areas = 24 chi-square tests; Sidak family rate 1e-3.
  const double alpha = sidak_alpha(1e-3, 24);
  int tests = 0;
  for (const std::string name : {"nearest", "zk16_linear", "distributed", "roulette"}) {
    for (const std::string inner : {"binomial", "gated"}) {
      LawParams params;
      if (name == "roulette") params["epsilon"] = 0.0;
      const auto law = blended(name, inner, 4, kALo, params);
      for (double cells : {21.0, 37.5, 58.0}) {
        const auto x = rounded(draw(law, kN, cells / kN, 0.15, 40000, 7 + static_cast<std::uint64_t>(tests)));
        const auto r = chi2_test(x.data(), x.size(), law.pmf(kN, cells / kN, 0.15));
        INFO(name << " inner " << inner << " cells " << cells << ": p = " << r.pvalue << " " << r.note);
        CHECK(r.pvalue > alpha);
        ++tests;
      }
    }
  }
  CHECK(tests == 24);
}

TEST_CASE("negative controls: ZK16 and a mis-weighted distributed law are rejected against the ground truth",
          "[blend][statistical]") {
  // The distributed law with the LOD weight w in place of the area weight (the mistake eq. 10's
  // misprint invites): its mean is off, and the chi-square test must see it.
  class WrongWeights final : public BlendRule {
   public:
    std::string name() const override { return "wrong"; }
    std::array<double, 2> trials(double density, double, const LevelBracket& b) const override {
      return {(1 - b.w_lod) * density * b.area_lo, b.w_lod * density * b.area_hi};
    }
    double combine(double, const LevelBracket&, double lo, double hi, std::array<FacetStream, 2>&) const override {
      return lo + hi;
    }
    bool integer_output() const override { return true; }
    Distribution combine_pmf(double, const LevelBracket&, const Distribution& lo, const Distribution& hi,
                             std::size_t max_support) const override {
      return convolve(lo, hi, max_support, "wrong");
    }
  };
  const BlendedLaw wrong(std::make_unique<WrongWeights>(),
                         InnerLaw::from_law(std::shared_ptr<const CountingLaw>(make_law("binomial"))),
                         LevelLadder(4, kALo));
  const double cells = 40;
  const Distribution truth = binomial::distribution(cells, 0.15);
  const auto xw = draw(wrong, kN, cells / kN, 0.15, 40000, 3);
  CHECK(chi2_test(xw.data(), xw.size(), truth).pvalue < 1e-6);
  const auto xz = rounded(draw(blended("zk16_linear", "binomial", 4, kALo), kN, cells / kN, 0.15, 40000, 3));
  CHECK(chi2_test(xz.data(), xz.size(), truth).pvalue < 1e-6);
  const auto xd = draw(blended("distributed", "binomial", 4, kALo), kN, cells / kN, 0.15, 40000, 3);
  CHECK(chi2_test(xd.data(), xd.size(), truth).pvalue > 1e-3);
}

TEST_CASE("ZK16's variance is the analytic fraction P[(1-w)^2/A_lo + w^2/A_hi] of the binomial's",
          "[blend][statistical]") {
  const auto law = blended("zk16_linear", "binomial", 4, kALo);
  for (double cells : {24.0, 32.0, 48.0}) {
    const double P = cells / kN, p = 0.2;
    const auto b = law.ladder().bracket(P);
    const double ratio = P * ((1 - b.w_lod) * (1 - b.w_lod) / b.area_lo + b.w_lod * b.w_lod / b.area_hi);
    const auto x = draw(law, kN, P, p, 200000, 11);
    const double expected = ratio * cells * p * (1 - p);
    // Standard error of a sample variance: sqrt((mu4 - sigma^4) / n) < sigma^2 sqrt(3 / n) here
    // (near-normal counts); 5 standard errors: a false failure below 1e-6.
    INFO("cells " << cells << " ratio " << ratio);
    CHECK(mean(x) == Approx(cells * p).margin(5 * std::sqrt(expected / 200000.0)));
    CHECK(std::abs(variance(x) - expected) < 5 * expected * std::sqrt(3.0 / 200000));
    CHECK(ratio < 0.8);
  }
}

TEST_CASE("roulette: the hard and the mollified roulette both have mean N P p", "[blend][statistical]") {
  for (double w : {0.2, 0.5, 0.8}) {
    const auto m = blend_detail::roulette_moments(w, 0.1);
    CHECK(m[0] == Approx(w).epsilon(1e-12));
    CHECK(m[1] < m[0]);
  }
  // Near the ends the smoothstep's mean is not the weight (KPT25's mollifier is biased there).
  CHECK(std::abs(blend_detail::roulette_moments(0.03, 0.1)[0] - 0.03) > 1e-3);
  CHECK(blend_detail::roulette_moments(0.0, 0.1)[0] == 0.0);
  CHECK(blend_detail::roulette_moments(1.0, 0.1)[0] == Approx(1.0).epsilon(1e-14));
  // Moments against a 200000-point midpoint rule.
  for (double w : {0.03, 0.5, 0.97}) {
    double s1 = 0, s2 = 0;
    const int q = 200000;
    for (int i = 0; i < q; ++i) {
      const double v = blend_detail::roulette_keep((i + 0.5) / q, w, 0.1);
      s1 += v;
      s2 += v * v;
    }
    const auto m = blend_detail::roulette_moments(w, 0.1);
    CHECK(m[0] == Approx(s1 / q).epsilon(1e-6));
    CHECK(m[1] == Approx(s2 / q).epsilon(1e-6));
  }
  for (double eps : {0.0, 0.1}) {
    LawParams params{{"epsilon", eps}};
    const auto law = blended("roulette", "binomial", 4, kALo, params);
    // 20 cells (w = 0.16): explicit facets; 5000 cells (a mid-level at 4096 + 1e3): the normal sum.
    for (double cells : {20.0, 40.0, 5000.0}) {
      const double P = cells / kN, p = 0.3;
      const auto b = law.ladder().bracket(P);
      const auto m_lo = blend_detail::roulette_moments(1 - b.w_lod, eps);
      const auto m_hi = blend_detail::roulette_moments(b.w_lod, eps);
      const double expected = kN * P * p * (m_lo[0] + m_hi[0]);  // sum over levels of (P/A_l) N A_l p m_l
      const auto x = draw(law, kN, P, p, 100000, 5);
      const double se = std::sqrt(variance(x) / static_cast<double>(x.size()));
      INFO("eps " << eps << " cells " << cells << " w " << b.w_lod);
      CHECK(std::abs(mean(x) - expected) < 5 * se);
      // Each level's keep rate is off near w = 0 and 1, but the two errors cancel exactly.
      CHECK(expected == Approx(cells * p).epsilon(1e-12));
    }
  }
}

TEST_CASE("positioned draws are coherent (one level cell, one count) and do not depend on threads", "[blend]") {
  const auto law = blended("distributed", "binomial", 4, 1.0);
  const double N = 1e8, p = 0.05;
  // P just above A_lo = 4^-9 (cells of side 2^-9): the lower level carries almost all trials.
  const double P = std::pow(4.0, -9) * 1.0001;
  std::vector<double> xs, ys;
  for (int i = 0; i < 50; ++i) {
    xs.push_back(0.25 + i * 1e-5);  // all inside one cell of side 2^-9 = 1.95e-3
    ys.push_back(0.5);
  }
  std::vector<double> k(xs.size());
  law.sample_at(N, {&P, 1}, {&p, 1}, {xs.data(), xs.size()}, {ys.data(), ys.size()}, xs.size(), 9, k.data());
  for (double v : k) CHECK(v == k[0]);
  // Zoom: the same position at growing P changes K by small steps (inverse-CDF coupling).
  std::vector<double> areas;
  for (int s = 0; s <= 64; ++s) areas.push_back(std::pow(4.0, -9) * std::pow(4.0, s / 64.0));
  std::vector<double> kz(areas.size());
  const double x0 = 0.25, y0 = 0.5;
  law.sample_at(N, {areas.data(), areas.size()}, {&p, 1}, {&x0, 1}, {&y0, 1}, areas.size(), 9, kz.data());
  double total_jump = 0;
  for (std::size_t s = 1; s < kz.size(); ++s) total_jump += std::abs(kz[s] - kz[s - 1]);
  CHECK(kz.front() == k[0]);
  CHECK(total_jump < 4 * std::abs(kz.back() - kz.front()) + 40);
  // Threads.
  const double Pm = 30.0 / kN;
  set_num_threads(1);
  const auto one = draw(blended("roulette", "gated", 4, kALo), kN, Pm, 0.2, 50000, 4);
  set_num_threads(2);
  const auto two = draw(blended("roulette", "gated", 4, kALo), kN, Pm, 0.2, 50000, 4);
  CHECK(one == two);
}

TEST_CASE("bad input is refused, naming the parameter", "[blend]") {
  const auto law = blended("distributed");
  const double P = 0.1, p = 0.5, bad_p = 1.5, bad_P = -1, nan = NAN;
  double out[1];
  CHECK_THROWS_WITH(law.sample(-1, {&P, 1}, {&p, 1}, 1, 1, out), Catch::Contains("N = -1"));
  CHECK_THROWS_WITH(law.sample(10, {&bad_P, 1}, {&p, 1}, 1, 1, out), Catch::Contains("P = -1"));
  CHECK_THROWS_WITH(law.sample(10, {&nan, 1}, {&p, 1}, 1, 1, out), Catch::Contains("P = nan"));
  CHECK_THROWS_WITH(law.sample(10, {&P, 1}, {&bad_p, 1}, 1, 1, out), Catch::Contains("p = 1.5"));
  CHECK_THROWS_WITH(law.sample_at(10, {&P, 1}, {&p, 1}, {&nan, 1}, {&P, 1}, 1, 1, out), Catch::Contains("x = nan"));
  CHECK_THROWS_WITH(law.pmf(NAN, P, p), Catch::Contains("N = nan"));
  CHECK_THROWS_WITH(make_blend("linear"), Catch::Contains("unknown blend 'linear'; known: distributed"));
  CHECK_THROWS_WITH(make_blend("roulette", {{"epsilon", 0.75}}), Catch::Contains("epsilon = 0.75"));
  CHECK_THROWS_WITH(make_blend("nearest", {{"epsilon", 0.1}}), Catch::Contains("epsilon"));
  CHECK_THROWS_AS(blended("roulette", "binomial", 4, 1, {{"epsilon", 0.1}}).pmf(100, 0.3, 0.1), not_implemented);
  CHECK_THROWS_AS(blended("distributed", "gated_continuous").pmf(100, 0.3, 0.1), not_implemented);
}

// Footprints an ulp either side of a level boundary (found by the extremes suite): trial counts a few
// ulps off an integer must not add a facet, so K never exceeds ceil(N P), even at p = 1.
TEST_CASE("no facet beyond ceil(N P) an ulp either side of a level boundary", "[blend]") {
  const double boundary = 4.0;  // level 1 of the default ladder
  for (const char* name : {"nearest", "zk16_linear", "distributed", "roulette"}) {
    const BlendedLaw law = blended(name);
    for (double P : {std::nextafter(boundary, 0.0), boundary, std::nextafter(boundary, 10.0)}) {
      for (double n : {1.0, 16.0, 1e9, 1e15}) {
        const double N = n / P, top = std::ceil(N * P);
        INFO(name << " P " << P << " n " << n);
        auto k = draw(law, N, P, 1.0, 512, 3);
        for (double& x : k) x = std::floor(x + 0.5);  // real outputs (rescaled counts) binned as their pmf
        CHECK(*std::max_element(k.begin(), k.end()) <= top);
        if (law.has_pmf() && n <= 1e9) {
          const Distribution d = law.pmf(N, P, 1.0);
          CHECK(d.support().back() <= top);
        }
      }
    }
  }
}
