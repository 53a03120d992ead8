// The law registry, parameter reading, and the vectorized drivers' determinism and validation.
#include <omp.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"

using namespace glintlab;
using Catch::Matchers::Contains;

TEST_CASE("laws are registered by name", "[law]") {
  std::vector<std::string> names;
  for (const auto& info : registered_laws()) names.push_back(info.name);
  CHECK(std::find(names.begin(), names.end(), "binomial") != names.end());
  CHECK(std::find(names.begin(), names.end(), "poisson") != names.end());
  CHECK_THROWS_WITH(make_law("nope"), Contains("unknown law 'nope'") && Contains("binomial"));
  CHECK_THROWS_WITH(make_law("binomial", {{"cap", 3.0}}), Contains("unknown parameter 'cap'"));
  auto law = make_law("binomial");
  CHECK(law->has_pmf());
  CHECK(law->n_uniforms() == 1);
}

TEST_CASE("ParamReader reads, defaults and rejects", "[law]") {
  const LawParams params{{"cap", 8.0}, {"rounding", std::string("round")}};
  ParamReader r("demo", params);
  CHECK(r.number("cap", 16) == 8.0);
  CHECK(r.number("missing", 3) == 3.0);
  CHECK(r.text("rounding", "floor", {"floor", "round"}) == "round");
  CHECK_NOTHROW(r.finish());
  ParamReader bad("demo", {{"rounding", std::string("up")}});
  CHECK_THROWS_WITH(bad.text("rounding", "floor", {"floor", "round"}), Contains("rounding = 'up'"));
  ParamReader wrong_type("demo", {{"cap", std::string("x")}});
  CHECK_THROWS_WITH(wrong_type.number("cap", 16), Contains("cap = 'x'"));
}

TEST_CASE("sampling is deterministic whatever the number of threads", "[law][determinism]") {
  auto law = make_law("binomial");
  const int saved = num_threads();
  for (auto [n, p] : {std::pair{16.0, 0.1}, {1e6, 0.3}, {10.5, 0.7}}) {
    std::vector<double> one(50'000), two(50'000), again(50'000);
    set_num_threads(1);
    sample_many(*law, {&n, 1}, {&p, 1}, one.size(), 99, one.data());
    set_num_threads(2);
    sample_many(*law, {&n, 1}, {&p, 1}, two.size(), 99, two.data());
    sample_many(*law, {&n, 1}, {&p, 1}, again.size(), 99, again.data());
    INFO("n = " << n << ", p = " << p);
    CHECK(one == two);
    CHECK(two == again);
    // Sample i depends on i only: a shorter batch is a prefix of a longer one.
    std::vector<double> prefix(1000);
    sample_many(*law, {&n, 1}, {&p, 1}, prefix.size(), 99, prefix.data());
    CHECK(std::equal(prefix.begin(), prefix.end(), one.begin()));
  }
  set_num_threads(saved);
}

namespace {
// Counts the evaluations that ran inside an OpenMP parallel region.
class ThreadProbeLaw final : public CountingLaw {
 public:
  std::string name() const override { return "thread_probe"; }
  int n_uniforms() const override { return 1; }
  double evaluate(double, double p, const double* u) const override {
    if (omp_in_parallel()) in_region.fetch_add(1, std::memory_order_relaxed);
    return u[0] < p ? 1.0 : 0.0;
  }
  mutable std::atomic<std::size_t> in_region{0};
};
}  // namespace

TEST_CASE("short batches run on the calling thread, long ones on the team", "[law][threads]") {
  // A parallel region's end waits for every thread of its team: on a loaded machine a descheduled
  // worker made a short batch pay milliseconds (docs/guide/performance.md#threads-on-a-loaded-machine).
  const int saved = num_threads();
  set_num_threads(2);
  ThreadProbeLaw law;
  const double n = 10, p = 0.5;
  std::vector<double> ns(100'000, n), ps(100'000, p), out(100'000);
  for (std::size_t count : {1000, 4000, 10'000, 16'383}) {
    INFO(count << " samples");
    law.in_region = 0;
    sample_many(law, {&n, 1}, {&p, 1}, count, 5, out.data());
    sample_many(law, {ns.data(), count}, {ps.data(), count}, count, 5, out.data());
    std::vector<double> u(count, 0.25);
    evaluate_many(law, {&n, 1}, {&p, 1}, u.data(), count, out.data());
    CHECK(law.in_region == 0);
  }
  law.in_region = 0;
  sample_many(law, {&n, 1}, {&p, 1}, out.size(), 5, out.data());
  CHECK(law.in_region > 0);  // a long batch still uses both threads
  set_num_threads(1);
  law.in_region = 0;
  sample_many(law, {&n, 1}, {&p, 1}, out.size(), 5, out.data());
  CHECK(law.in_region == 0);  // one thread: no region at all
  set_num_threads(saved);
}

TEST_CASE("drivers validate every element and name it", "[law][errors]") {
  auto law = make_law("poisson");
  std::vector<double> n{1, 2, -3, 4}, p{0.5}, out(4);
  CHECK_THROWS_WITH(sample_many(*law, {n.data(), 4}, {p.data(), 1}, 4, 1, out.data()), Contains("n[2] = -3"));
  n[2] = 3;
  std::vector<double> pbad{0.5, 0.5, 0.5, NAN};
  CHECK_THROWS_WITH(sample_many(*law, {n.data(), 4}, {pbad.data(), 4}, 4, 1, out.data()), Contains("p[3] = nan"));
  std::vector<double> u{0.1, 0.2, 1.5, 0.3};
  CHECK_THROWS_WITH(evaluate_many(*law, {n.data(), 4}, {p.data(), 1}, u.data(), 4, out.data()),
                    Contains("u[2, 0] = 1.5"));
  CHECK_THROWS_WITH(sample_many(*law, {n.data(), 3}, {p.data(), 1}, 4, 1, out.data()), Contains("n has 3 values"));
  CHECK_THROWS_WITH(set_num_threads(0), Contains("threads = 0"));
}

TEST_CASE("the per-pixel driver's fused check names the lowest bad pixel on any thread count",
          "[law][errors][pixels]") {
  // Two arrays: the check runs inside the draw pass, block by block on every thread; the message must
  // still name the lowest bad index, as a serial scan first would. Bad pixels in several chunks (4096
  // pixels each), one inside a run of equal pixels that crosses a block's end (2048).
  auto law = make_law("gated");
  const std::size_t m = 20000;
  std::vector<double> n(m), p(m), out(m);
  for (std::size_t i = 0; i < m; ++i) {
    n[i] = 1.0 + static_cast<double>(i % 97);
    p[i] = 0.01 * static_cast<double>(1 + i % 89);
  }
  for (std::size_t i = 2030; i < 2100; ++i) n[i] = 5, p[i] = 0.5;  // a run across the block end
  const int saved = num_threads();
  for (int threads : {1, 2, 3}) {
    set_num_threads(threads);
    auto bad_n = n, bad_p = p;
    bad_n[15000] = -1;
    bad_p[9001] = NAN;
    bad_n[17000] = NAN;
    bad_n[9500] = -1;  // a second one in the same block
    CHECK_THROWS_WITH(sample_many(*law, {bad_n.data(), m}, {bad_p.data(), m}, m, 1, out.data()),
                      Contains("p[9001] = nan"));
    bad_n[6144] = NAN;  // the first pixel of a block (the scan reads it apart from the rest)
    CHECK_THROWS_WITH(sample_many(*law, {bad_n.data(), m}, {bad_p.data(), m}, m, 1, out.data()),
                      Contains("n[6144] = nan"));
    bad_p[2060] = 1.5;  // inside the run
    CHECK_THROWS_WITH(sample_many(*law, {bad_n.data(), m}, {bad_p.data(), m}, m, 1, out.data()),
                      Contains("p[2060] = 1.5"));
    auto last = n;
    last[m - 1] = -2;
    CHECK_THROWS_WITH(sample_many(*law, {last.data(), m}, {p.data(), m}, m, 1, out.data()), Contains("n[19999] = -2"));
  }
  set_num_threads(saved);
}

TEST_CASE("evaluate inverts the exact cdf and fill_uniforms feeds the default sampler", "[law]") {
  auto law = make_law("binomial");
  const double n = 30, p = 0.2;
  std::vector<double> u(1000), k(1000);
  fill_uniforms(5, kStreamSample, 0, u.size(), 1, u.data());
  evaluate_many(*law, {&n, 1}, {&p, 1}, u.data(), u.size(), k.data());
  for (std::size_t i = 0; i < u.size(); ++i) {
    INFO("u = " << u[i] << ", K = " << k[i]);
    REQUIRE(k[i] >= 0);
    REQUIRE(k[i] <= n);
  }
  // Rows with offset `start` continue the same sequence.
  std::vector<double> tail(10);
  fill_uniforms(5, kStreamSample, 990, 10, 1, tail.data());
  CHECK(std::equal(tail.begin(), tail.end(), u.begin() + 990));
}

TEST_CASE("precision: templated laws run in float32, exact laws refuse it", "[law][precision]") {
  auto gauss = make_law("gaussian", {{"rounding", std::string("round")}});
  auto binom = make_law("binomial");
  CHECK(gauss->supports(Precision::kFloat32));
  CHECK_FALSE(binom->supports(Precision::kFloat32));
  CHECK(precision_from_name("float32") == Precision::kFloat32);
  CHECK_THROWS_WITH(precision_from_name("half"), Contains("unknown precision 'half'; known: float64, float32"));
  const double n = 1e6, p = 0.3;
  std::vector<double> out(4096), out32(4096);
  sample_many(*gauss, {&n, 1}, {&p, 1}, out.size(), 3, out.data(), Precision::kFloat64);
  sample_many(*gauss, {&n, 1}, {&p, 1}, out32.size(), 3, out32.data(), Precision::kFloat32);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < out.size(); ++i) differ += out[i] != out32[i];
  // float has a spacing of 0.03 at n p = 3e5: a few percent of the rounding boundaries move.
  CHECK(differ > 0);
  CHECK(differ < out.size() / 5);
  CHECK_THROWS_WITH(sample_many(*binom, {&n, 1}, {&p, 1}, 4, 3, out.data(), Precision::kFloat32),
                    Contains("precision = 'float32'"));
  // u = 0 and u = 1 (Phi^-1 infinite) and a degenerate sd stay finite and in range.
  for (double uu : {0.0, 1.0}) {
    for (auto [nn, pp] : {std::pair{16.0, 0.0}, {16.0, 1.0}, {0.0, 0.5}, {16.0, 0.5}}) {
      const double k = gauss->evaluate(nn, pp, &uu), k32 = gauss->evaluate_f32(nn, pp, &uu);
      INFO("n = " << nn << ", p = " << pp << ", u = " << uu << ": K = " << k << ", K32 = " << k32);
      CHECK((k >= 0 && k <= std::ceil(nn)));
      CHECK((k32 >= 0 && k32 <= std::ceil(nn)));
    }
  }
}

// The corners of the domain (found by the extremes suite: gated's pmf at n = 0, p = 1 was NaN, and
// zk16's Gaussian branch at p = 1 had zero mass). Every law with a pmf must give one there, and it
// must hold the counts evaluate produces.
TEST_CASE("pmf at the corners of the domain holds what evaluate produces", "[law][extremes]") {
  const std::vector<double> ns{0.0, 1e-6, 1.0, 16.0, 17.5, 1e9};
  const std::vector<double> ps{0.0, 1e-300, 0.5, 1.0};
  for (const auto& info : registered_laws()) {
    const auto law = make_law(info.name);
    if (!law->has_pmf()) continue;
    const int k = law->n_uniforms();
    for (double n : ns) {
      for (double p : ps) {
        INFO(info.name << " n " << n << " p " << p);
        Distribution d;
        REQUIRE_NOTHROW(d = law->pmf(n, p, 1u << 22));
        double mass = 0;
        for (double q : d.probs()) mass += q;
        CHECK(std::abs(mass - 1) < 1e-9);
        std::vector<double> u(static_cast<std::size_t>(std::max(k, 1)));
        for (double v : {1e-9, 0.25, 0.5, 0.75, 1 - 1e-9}) {
          std::fill(u.begin(), u.end(), v);
          double x = law->evaluate(n, p, u.data());
          if (law->binning() == "round") x = std::floor(x + 0.5);
          bool found = false;
          for (std::size_t i = 0; i < d.support().size(); ++i) found |= d.support()[i] == x && d.probs()[i] > 0;
          INFO("u " << v << " K " << x);
          CHECK(found);
        }
      }
    }
  }
}
