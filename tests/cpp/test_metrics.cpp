// Metrics on hand-computed cases and the chi-square test's binning and verdicts.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/chi2.hpp"
#include "glintlab/stats/metrics.hpp"

using namespace glintlab;
using Catch::Matchers::Contains;

namespace {
double d(const Distribution& a, const Distribution& b, const char* m) { return distance(a, b, metric_from_name(m)); }
}  // namespace

TEST_CASE("metrics on a hand-computed pair", "[metrics]") {
  // a = {0: 0.5, 1: 0.5}, b = {1: 0.25, 2: 0.75}.
  const Distribution a({0, 1}, {0.5, 0.5}), b({1, 2}, {0.25, 0.75});
  // TV = (0.5 + 0.25 + 0.75) / 2 = 0.75.
  CHECK(d(a, b, "tv") == Approx(0.75));
  // chi2 = 1/2 [0.25/0.5 + 0.0625/0.75 + 0.5625/0.75] = 1/2 [0.5 + 1/12 + 0.75] = 2/3.
  CHECK(d(a, b, "chi2_distance") == Approx(2.0 / 3));
  // Hellinger^2 = 1/2 [0.5 + (sqrt .5 - .5)^2 + 0.75] = 1 - sqrt(0.125).
  CHECK(d(a, b, "hellinger") == Approx(std::sqrt(1 - std::sqrt(0.125))));
  // KL(a || b) = inf (b(0) = 0); KL(b || a) = inf (a(2) = 0).
  CHECK(std::isinf(d(a, b, "kl")));
  // JS = 1/2 [.5 log(.5/.25) + .5 log(.5/.375)] + 1/2 [.25 log(.25/.375) + .75 log(.75/.375)].
  const double js = 0.5 * (0.5 * std::log(2.0) + 0.5 * std::log(0.5 / 0.375)) +
                    0.5 * (0.25 * std::log(0.25 / 0.375) + 0.75 * std::log(2.0));
  CHECK(d(a, b, "js") == Approx(js));
  // CDFs at 0, 1, 2: a = .5, 1, 1; b = 0, .25, 1 -> |diff| .5, .75, 0; W1 = .5 + .75 = 1.25.
  CHECK(d(a, b, "w1") == Approx(1.25));
  CHECK(d(a, b, "ks") == Approx(0.75));
}

TEST_CASE("metrics: identity, disjoint supports, symmetry, finite KL", "[metrics]") {
  const Distribution a({0, 1, 2}, {0.2, 0.5, 0.3}), b({0, 1, 2}, {0.3, 0.4, 0.3});
  for (const auto& m : metric_names()) {
    INFO("metric " << m);
    CHECK(distance(a, a, metric_from_name(m)) == Approx(0.0).margin(1e-15));
  }
  const Distribution x({0}, {1.0}), y({5}, {1.0});
  CHECK(d(x, y, "tv") == 1.0);
  CHECK(d(x, y, "hellinger") == 1.0);
  CHECK(d(x, y, "js") == Approx(std::log(2.0)));
  CHECK(d(x, y, "w1") == Approx(5.0));
  for (const char* m : {"tv", "chi2_distance", "hellinger", "js", "w1", "ks"}) CHECK(d(a, b, m) == Approx(d(b, a, m)));
  // KL(a || b) = .2 log(2/3) + .5 log(5/4).
  CHECK(d(a, b, "kl") == Approx(0.2 * std::log(2.0 / 3) + 0.5 * std::log(1.25)));
  CHECK_THROWS_WITH(metric_from_name("foo"), Contains("unknown metric 'foo'; known: tv, "));
}

TEST_CASE("empirical distributions", "[metrics][distribution]") {
  const double s[] = {3, 1, 3, 3, 2, 1};
  const Distribution e = Distribution::empirical(s, 6);
  CHECK(e.support() == std::vector<double>{1, 2, 3});
  CHECK(e.probs()[2] == Approx(0.5));
  CHECK(e.mean() == Approx(13.0 / 6));
  const double bad[] = {1, NAN};
  CHECK_THROWS_WITH(Distribution::empirical(bad, 2), Contains("samples[1] = nan"));
  CHECK_THROWS_WITH(Distribution({1, 0}, {0.5, 0.5}), Contains("support[1]"));
  CHECK_THROWS_WITH(Distribution({0, 1}, {0.5, 0.6}), Contains("sum(probs)"));
}

TEST_CASE("chi-square test: statistic, dof and tail merging", "[chi2]") {
  // Law {0: .5, 1: .3, 2: .15, 3: .05}; 100 samples: 45, 35, 12, 8.
  // Expected 50, 30, 15, 5: no merge needed (all >= 5). stat = 25/50 + 25/30 + 9/15 + 9/5.
  const Distribution law({0, 1, 2, 3}, {0.5, 0.3, 0.15, 0.05});
  std::vector<double> s;
  for (auto [v, c] : {std::pair{0, 45}, {1, 35}, {2, 12}, {3, 8}}) s.insert(s.end(), c, v);
  auto r = chi2_test(s.data(), s.size(), law);
  CHECK(r.statistic == Approx(0.5 + 25.0 / 30 + 0.6 + 1.8));
  CHECK(r.dof == 3);
  CHECK(r.expected.size() == 4);
  // With 60 samples the last expected is 3 < 5: it merges into the previous bin (9 + 3 = 12).
  s.resize(60);
  r = chi2_test(s.data(), s.size(), law);
  CHECK(r.expected.size() == 3);
  CHECK(r.expected.back() == Approx(12.0));
  for (double e : r.expected) CHECK(e >= 5.0);
}

TEST_CASE("chi-square test: impossible samples and trimmed tails", "[chi2]") {
  const Distribution law({0, 1, 2}, {0.25, 0.5, 0.25});
  std::vector<double> s(1000, 1.0);
  s[10] = 1.5;  // between support points
  auto r = chi2_test(s.data(), s.size(), law);
  CHECK(r.pvalue == 0.0);
  CHECK_THAT(r.note, Contains("probability 0"));
  s[10] = 3;  // beyond an untrimmed end
  CHECK(chi2_test(s.data(), s.size(), law).pvalue == 0.0);
  // A trimmed binomial: a value in the trimmed upper tail is counted in the last bin, not rejected.
  const Distribution bin = binomial::distribution(1e6, 0.3);
  REQUIRE(bin.trimmed_above());
  std::vector<double> t(2000, 300000.0);
  t[0] = bin.support().back() + 1;
  CHECK(chi2_test(t.data(), t.size(), bin).note.empty());
}

TEST_CASE("Sidak correction", "[chi2]") {
  CHECK(sidak_alpha(0.01, 1) == Approx(0.01));
  CHECK(1 - std::pow(1 - sidak_alpha(0.01, 20), 20) == Approx(0.01));
  CHECK_THROWS_WITH(sidak_alpha(0.0, 3), Contains("alpha = 0"));
}

TEST_CASE("chi-square test: too few samples for merged bins get the exact likelihood-ratio test", "[chi2]") {
  // Law {0: .5, 1: .3, 2: .15, 3: .05}; 6 samples merge into one bin of expected >= 5 (dof 0).
  const Distribution law({0, 1, 2, 3}, {0.5, 0.3, 0.15, 0.05});
  const std::vector<double> typical{0, 0, 1, 0, 2, 1};
  const auto r = chi2_test(typical.data(), typical.size(), law);
  CHECK(r.dof == 0);
  CHECK_THAT(r.note, Contains("exact likelihood-ratio"));
  CHECK(r.pvalue > 0.05);
  CHECK(chi2_test(typical.data(), typical.size(), law).pvalue == r.pvalue);  // a fixed key
  // Six samples on the value of mass 0.05: merging hid this. The 84 possible count vectors are
  // enumerated, and no other one has a G as large, so the p-value is exactly 0.05^6 = 1.5625e-8 (a
  // Monte Carlo estimate could not go below its resolution 1 / (1 + 9999)).
  const std::vector<double> rare(6, 3.0);
  const auto rr = chi2_test(rare.data(), rare.size(), law);
  CHECK(rr.pvalue == Approx(std::pow(0.05, 6)).epsilon(1e-12));
  CHECK(rr.resolution == 0.0);
  CHECK_THAT(rr.note, Contains("enumeration of all 84 outcomes"));
  // No degrees of freedom after fitted parameters: no test, a NaN p-value.
  CHECK(std::isnan(chi2_test(typical.data(), typical.size(), law, 5.0, 3).pvalue));
}
