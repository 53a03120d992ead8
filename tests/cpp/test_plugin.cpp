// Plugin laws (glintlab/plugin.h, validation/src/plugin_loader.cpp): the example plugin round trip
// against glintlab's exact binomial, determinism, and every refusal of the loader.
#include <dlfcn.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/chi2.hpp"
#include "glintlab/stats/metrics.hpp"
#include "glintlab/validation/plugin.hpp"

using namespace glintlab;
using Catch::Matchers::Contains;

namespace {

const std::string kExample = GLINTLAB_EXAMPLE_PLUGIN;
const std::string kBad = GLINTLAB_BAD_PLUGIN;

bool registered(const std::string& name) {
  for (const auto& info : registered_laws())
    if (info.name == name) return true;
  return false;
}

std::unique_ptr<CountingLaw> example(const std::string& name = "example_binomial_inversion") {
  load_plugin(kExample);
  return make_law(name);
}

std::vector<double> sample(const CountingLaw& law, double n, double p, std::size_t count, std::uint64_t seed) {
  std::vector<double> out(count);
  sample_many(law, {&n, 1}, {&p, 1}, count, seed, out.data());
  return out;
}

// Loads the broken plugin with GLINTLAB_BAD_PLUGIN_CASE = c and returns the error message.
std::string bad_load(const char* c) {
  ::setenv("GLINTLAB_BAD_PLUGIN_CASE", c, 1);
  try {
    load_plugin(kBad);
  } catch (const std::invalid_argument& e) { return e.what(); }
  return "(loaded)";
}

}  // namespace

TEST_CASE("the example plugin registers its laws like built-in ones", "[plugin]") {
  const auto names = load_plugin(kExample);
  REQUIRE(names == std::vector<std::string>{"example_binomial_inversion", "example_round_normal"});
  for (const auto& info : registered_laws())
    if (info.name == "example_binomial_inversion")
      CHECK_THAT(info.summary, Contains("(plugin libglintlab_example_plugin.so)"));
  CHECK(registered("example_round_normal"));

  const auto inv = make_law("example_binomial_inversion");
  CHECK(inv->name() == "example_binomial_inversion");
  CHECK(inv->n_uniforms() == 1);
  CHECK(inv->has_pmf());
  CHECK(inv->binning() == "none");
  CHECK_FALSE(inv->supports(Precision::kFloat32));
  const auto rn = make_law("example_round_normal");
  CHECK(rn->binning() == "round");
  CHECK_FALSE(rn->has_pmf());
  CHECK_THROWS_AS(rn->pmf(10, 0.5, kDefaultMaxSupport), not_implemented);
  CHECK_THROWS_WITH(make_law("example_round_normal", {{"cap", 3.0}}), Contains("unknown parameter 'cap'"));

  // Loading again, under the same or another spelling of the path, changes nothing.
  const auto slash = kExample.rfind('/');
  const std::string dotted = kExample.substr(0, slash) + "/./" + kExample.substr(slash + 1);
  CHECK(load_plugin(kExample) == names);
  CHECK(load_plugin(dotted) == names);
  int seen = 0;
  for (const auto& p : loaded_plugins())
    if (p.laws == names) ++seen;
  CHECK(seen == 1);
}

TEST_CASE("plugin samples are the plugin's evaluate on the batch uniforms", "[plugin]") {
  for (const char* name : {"example_binomial_inversion", "example_round_normal"}) {
    const auto law = example(name);
    for (auto [n, p] : {std::pair{30.0, 0.2}, {10.5, 0.7}, {2e5, 0.4}}) {
      for (std::size_t count : {std::size_t{40}, std::size_t{5000}}) {  // below and above the batch-sampler size
        const auto x = sample(*law, n, p, count, 7);
        std::vector<double> u(count), y(count);
        fill_uniforms(7, kStreamSample, 0, count, 1, u.data());
        evaluate_many(*law, {&n, 1}, {&p, 1}, u.data(), count, y.data());
        INFO(name << " n = " << n << ", p = " << p << ", count = " << count);
        CHECK(x == y);
      }
    }
    // Per-sample (n, p) arrays take the drivers' other path.
    std::vector<double> ns{5, 5, 6, 7.5, 100}, ps{0.1, 0.1, 0.5, 0.9, 0.01}, x(5), u(5), y(5);
    sample_many(*law, {ns.data(), 5}, {ps.data(), 5}, 5, 3, x.data());
    fill_uniforms(3, kStreamSample, 0, 5, 1, u.data());
    evaluate_many(*law, {ns.data(), 5}, {ps.data(), 5}, u.data(), 5, y.data());
    CHECK(x == y);
  }
}

TEST_CASE("plugin sampling does not depend on the number of threads", "[plugin][determinism]") {
  const int saved = num_threads();
  for (const char* name : {"example_binomial_inversion", "example_round_normal"}) {
    const auto law = example(name);
    set_num_threads(1);
    const auto one = sample(*law, 1000, 0.3, 50'000, 11);
    set_num_threads(2);
    const auto two = sample(*law, 1000, 0.3, 50'000, 11);
    CHECK(one == two);
  }
  set_num_threads(saved);
}

TEST_CASE("the example pmf is glintlab's exact binomial", "[plugin]") {
  const auto law = example();
  for (auto [n, p] : {std::pair{10.0, 0.3},
                      {100.0, 0.01},
                      {1000.0, 0.5},
                      {1e4, 0.999},
                      {1e5, 1e-3},
                      {10.5, 0.7},
                      {0.4, 0.9},
                      {7.25, 1.0},
                      {50.0, 0.0},
                      {3.0, 1e-300}}) {
    const Distribution mine = law->pmf(n, p, kDefaultMaxSupport);
    const Distribution exact = binomial::distribution(n, p);
    INFO("n = " << n << ", p = " << p);
    CHECK(distance(mine, exact, Metric::kTV) < 1e-12);
    CHECK(std::abs(mine.mean() - n * p) < 1e-9 * std::max(1.0, n * p));
  }
  // Inversion: the plugin's K is binomial::quantile(u) but where the cdf is within rounding of u.
  std::vector<double> u(20'000);
  fill_uniforms(5, kStreamSample, 0, u.size(), 1, u.data());
  for (auto [n, p] : {std::pair{30.0, 0.2}, {1000.0, 0.5}, {10.5, 0.7}}) {
    int differ = 0;
    for (double v : u) differ += law->evaluate(n, p, &v) != binomial::quantile(v, n, p);
    CHECK(differ <= 2);
  }
  for (double v : {0.0, 1.0}) {  // end points give finite, possible counts
    const double k = law->evaluate(20, 0.5, &v);
    CHECK((k >= 0 && k <= 20));
  }
  // Outside its exact domain (n > 1e5) the example has no pmf, and says so with (n, p).
  CHECK_THROWS_AS(law->pmf(2e5, 0.5, kDefaultMaxSupport), not_implemented);
  CHECK_THROWS_WITH(law->pmf(2e5, 0.5, kDefaultMaxSupport), Contains("(n, p) = (200000, 0.5)"));
  // A support beyond max_support (the loader's retries stop there).
  CHECK_THROWS_WITH(law->pmf(1e5, 0.5, 100), Contains("max_support"));
}

TEST_CASE("plugin samples pass a chi-square test against the plugin pmf", "[plugin][statistical]") {
  // Three tests at family-wise false-failure rate 1e-4 (fixed seed: the outcome is deterministic).
  const double alpha = sidak_alpha(1e-4, 3);
  const auto law = example();
  for (auto [n, p] : {std::pair{30.0, 0.2}, {10.5, 0.7}, {1000.0, 0.5}}) {
    const auto x = sample(*law, n, p, 200'000, 21);
    const auto r = chi2_test(x.data(), x.size(), law->pmf(n, p, kDefaultMaxSupport));
    INFO("n = " << n << ", p = " << p << ": chi2 = " << r.statistic << ", dof = " << r.dof);
    CHECK(r.pvalue > alpha);
  }
  // Negative control: samples at p = 0.21 against the law at p = 0.2 (mean off by 0.14 sd).
  const auto off = sample(*law, 30, 0.21, 200'000, 21);
  CHECK(chi2_test(off.data(), off.size(), law->pmf(30, 0.2, kDefaultMaxSupport)).pvalue < 1e-12);
  // The shader-style law, binned round half up, is glintlab's gaussian(rounding = round) at integer n.
  const auto rn = example("example_round_normal");
  auto y = sample(*rn, 40, 0.3, 200'000, 22);
  for (double& v : y) v = std::floor(v + 0.5);
  const auto g = make_law("gaussian", {{"rounding", std::string("round")}});
  CHECK(chi2_test(y.data(), y.size(), g->pmf(40, 0.3, kDefaultMaxSupport)).pvalue > 1e-4);
}

TEST_CASE("the loader refuses missing files and non-plugins, naming the path", "[plugin][errors]") {
  CHECK_THROWS_WITH(load_plugin("/nonexistent/libnothing.so"),
                    Contains("plugin '/nonexistent/libnothing.so'") && Contains("no such file"));
  CHECK_THROWS_AS(load_plugin(""), std::invalid_argument);
  // A file that is not a shared library: dlopen's message.
  const std::string readme = std::string(GLINTLAB_SOURCE_DIR) + "/README.md";
  CHECK_THROWS_WITH(load_plugin(readme), Contains(readme) && Contains("cannot load the library"));
  // A shared library without the entry point (the C maths library).
  Dl_info info{};
  double (*cosine)(double) = &::cos;
  void* address = nullptr;
  std::memcpy(&address, &cosine, sizeof address);
  REQUIRE(dladdr(address, &info) != 0);
  const std::string libm = info.dli_fname;
  CHECK_THROWS_WITH(load_plugin(libm), Contains(libm) && Contains("does not export glintlab_plugin_laws_v1"));
}

TEST_CASE("the loader refuses bad tables and checks plugin pmfs", "[plugin][errors]") {
  // One test case: once the broken plugin loads (last case), its path is cached.
  const std::string at = "plugin '" + kBad + "'";
  CHECK_THAT(bad_load("n_uniforms"),
             Contains(at) && Contains("law 'bad_k': n_uniforms = 9 is invalid; expected 0 to 4"));
  CHECK_THAT(bad_load("empty_name"), Contains("laws[0].name = '' is invalid"));
  CHECK_THAT(bad_load("bad_name"), Contains("laws[0].name = 'has space' is invalid"));
  CHECK_THAT(bad_load("null_name"), Contains("laws[0].name = NULL is invalid"));
  CHECK_THAT(bad_load("null_evaluate"), Contains("law 'bad_eval': evaluate = NULL is invalid"));
  CHECK_THAT(bad_load("binning"), Contains("binning = 'floor' is invalid; expected 'none' or 'round'"));
  CHECK_THAT(bad_load("duplicate"), Contains("laws[1].name = 'bad_twice'") && Contains("used once"));
  CHECK_THAT(bad_load("clash"), Contains("laws[1].name = 'binomial'") && Contains("a built-in law has it"));
  // A name reserved by the caller (the Python layer passes its custom laws' names).
  ::setenv("GLINTLAB_BAD_PLUGIN_CASE", "clash", 1);
  CHECK_THROWS_WITH(load_plugin(kBad, {"bad_fine"}),
                    Contains("laws[0].name = 'bad_fine'") && Contains("a Python custom law has it"));
  CHECK_THAT(bad_load("empty"), Contains("count = 0 is invalid"));
  CHECK_THAT(bad_load("null_table"), Contains("NULL table"));
  CHECK_FALSE(registered("bad_fine"));  // nothing of a refused table is registered
  CHECK_FALSE(registered("bad_twice"));

  ::unsetenv("GLINTLAB_BAD_PLUGIN_CASE");
  const auto names = load_plugin(kBad);
  CHECK(names.size() == 7);
  const auto law = [](const char* name) { return make_law(name); };
  CHECK_THROWS_WITH(law("bad_pmf_sum")->pmf(3, 0.5, kDefaultMaxSupport),
                    Contains("plugin law 'bad_pmf_sum'") && Contains("(n, p) = (3, 0.5)") && Contains("sum to 0.5"));
  CHECK_THROWS_WITH(law("bad_pmf_negative")->pmf(3, 0.5, kDefaultMaxSupport), Contains("probs[1] (k = 1) = -0.5"));
  CHECK_THROWS_WITH(law("bad_pmf_nan")->pmf(3, 0.5, kDefaultMaxSupport), Contains("probs[0] (k = 0) = nan"));
  CHECK_THROWS_WITH(law("bad_pmf_overflow")->pmf(3, 0.5, kDefaultMaxSupport), Contains("returned length 4097"));
  CHECK_THROWS_AS(law("bad_pmf_sum")->pmf(3, 0.5, kDefaultMaxSupport), std::runtime_error);
  CHECK_THROWS_AS(law("bad_pmf_none")->pmf(3, 0.5, kDefaultMaxSupport), not_implemented);
  // A support larger than the first buffer: the loader asks again with more room.
  CHECK(law("bad_pmf_wide")->pmf(3, 0.5, kDefaultMaxSupport).size() == 10'000);
  CHECK_THROWS_WITH(law("bad_pmf_wide")->pmf(3, 0.5, 5000), Contains("more than 5000 points"));
  // A NaN from evaluate is passed through (documented in plugin.h); sample-based laws refuse it.
  const auto nan_law = law("bad_nan_eval");
  const auto x = sample(*nan_law, 3, 0.9, 10, 1);
  CHECK(std::isnan(x[0]));
  CHECK_THROWS_AS(Distribution::empirical(x.data(), x.size()), std::invalid_argument);
}
