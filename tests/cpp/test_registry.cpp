// The one Registry template (registry.hpp) behind laws, blends and grid schemes, and the traits each
// law declares in its own file. The traits replace name lists kept elsewhere, so they are checked
// against what the law actually does: a wrong declaration fails here, next to the law.
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "glintlab/base/registry.hpp"
#include "glintlab/counting/aniso.hpp"
#include "glintlab/counting/blend.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/chi2.hpp"
#include "glintlab/stats/metrics.hpp"
#include "glintlab/validation/plugin.hpp"

using namespace glintlab;
using Catch::Matchers::Contains;

namespace {

struct ThingInfo {
  std::string name;
  std::function<int(int)> make;
};

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) { return e.what(); }
  return "(no std::invalid_argument)";
}

// Removes a law registered by a test when the test ends, also when a REQUIRE fails half-way, so no
// later test sees it in registered_laws().
struct LawRegistration {
  std::string name;
  explicit LawRegistration(LawInfo info) : name(info.name) { register_law(std::move(info)); }
  ~LawRegistration() { law_registry().remove(name); }
  LawRegistration(const LawRegistration&) = delete;
  LawRegistration& operator=(const LawRegistration&) = delete;
};

}  // namespace

TEST_CASE("a registry adds, finds, makes, lists and removes by name", "[registry]") {
  Registry<ThingInfo> things("thing");
  CHECK(things.names().empty());
  CHECK(message_of([&] { things.find("a"); }) == "unknown thing 'a'; known: (none)");

  // Added out of order: listings are sorted, so they do not depend on static initialization order.
  CHECK(things.add({"c", [](int x) { return x + 3; }}));
  CHECK(things.add({"a", [](int x) { return x + 1; }}));
  CHECK(things.add({"b", [](int x) { return x + 2; }}));
  CHECK(things.names() == std::vector<std::string>{"a", "b", "c"});
  REQUIRE(things.all().size() == 3);
  CHECK(things.all()[1].name == "b");
  CHECK(things.make("b", 40) == 42);
  CHECK(things.contains("a"));
  CHECK(things.try_find("a").has_value());
  CHECK_FALSE(things.try_find("z").has_value());

  // A duplicate is a programming error, and leaves the first entry in place.
  CHECK_THROWS_AS(things.add({"a", [](int x) { return x; }}), std::logic_error);
  CHECK_THROWS_WITH(things.add({"a", [](int x) { return x; }}), "thing registered twice: a");
  CHECK(things.make("a", 1) == 2);
  CHECK_THROWS_AS(things.add({"", [](int x) { return x; }}), std::logic_error);

  // One message for every unknown name, listing the known ones.
  CHECK_THROWS_AS(things.make("zz", 0), std::invalid_argument);
  CHECK(message_of([&] { things.make("zz", 0); }) == "unknown thing 'zz'; known: a, b, c");
  CHECK(things.unknown_message("zz") == "unknown thing 'zz'; known: a, b, c");

  CHECK(things.remove("b"));
  CHECK_FALSE(things.remove("b"));
  CHECK(things.names() == std::vector<std::string>{"a", "c"});
  CHECK(message_of([&] { things.find("b"); }) == "unknown thing 'b'; known: a, c");
}

TEST_CASE("a factory may use its own registry (factories run outside the lock)", "[registry]") {
  Registry<ThingInfo> things("thing");
  things.add({"base", [](int x) { return 2 * x; }});
  things.add({"derived", [&things](int x) { return things.make("base", x) + 1; }});
  CHECK(things.make("derived", 5) == 11);
}

TEST_CASE("a registry is safe under concurrent registration, lookup and removal", "[registry][threads]") {
  Registry<ThingInfo> things("thing");
  things.add({"fixed", [](int x) { return x; }});
  constexpr int kThreads = 8, kPerThread = 200;
  std::atomic<int> wrong{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        // (appended piecewise: GCC 12 gives a false -Wrestrict on "literal" + std::to_string(...))
        std::string name = std::to_string(t);
        name.append("_").append(std::to_string(i));
        things.add({name, [i](int x) { return x + i; }});
        if (things.make(name, 1) != 1 + i) ++wrong;
        if (things.make("fixed", 7) != 7) ++wrong;
        if (things.names().empty()) ++wrong;
        if (i % 2 == 0 && !things.remove(name)) ++wrong;
      }
    });
  }
  for (auto& th : threads) th.join();
  CHECK(wrong == 0);
  CHECK(things.names().size() == 1 + kThreads * kPerThread / 2);

  // The same through the law registry, while other threads make and list laws: plugins register
  // after static initialization, possibly while a renderer's threads look laws up.
  std::vector<std::unique_ptr<LawRegistration>> added(kThreads);
  std::vector<std::thread> users;
  std::atomic<bool> stop{false};
  for (int t = 0; t < 2; ++t) {
    users.emplace_back([&] {
      while (!stop) {
        if (make_law("binomial")->name() != "binomial") ++wrong;
        if (registered_laws().empty()) ++wrong;
      }
    });
  }
  std::vector<std::thread> writers;
  for (int t = 0; t < kThreads; ++t) {
    writers.emplace_back([&, t] {
      const std::string name = "registry_thread_law_" + std::to_string(t);
      added[static_cast<std::size_t>(t)] = std::make_unique<LawRegistration>(
          LawInfo{name, "test", [](const LawParams&) { return make_law("binomial"); }});
      if (make_law(name)->name() != "binomial") ++wrong;
    });
  }
  for (auto& th : writers) th.join();
  stop = true;
  for (auto& th : users) th.join();
  CHECK(wrong == 0);
  for (int t = 0; t < kThreads; ++t) CHECK(law_registry().contains("registry_thread_law_" + std::to_string(t)));
  added.clear();
  for (int t = 0; t < kThreads; ++t) CHECK_FALSE(law_registry().contains("registry_thread_law_" + std::to_string(t)));
}

TEST_CASE("laws, blends and grid schemes refuse unknown names with one message", "[registry]") {
  CHECK(message_of([] { make_law("nope"); }) == "unknown law 'nope'; known: " + joined(law_registry().names()));
  CHECK_THAT(message_of([] { make_law("nope"); }), Contains("binomial"));
  CHECK(message_of([] { make_blend("linear"); }) ==
        "unknown blend 'linear'; known: distributed, nearest, roulette, zk16_linear");
  CHECK(message_of([] { aniso::make_grid_scheme("db99"); }) ==
        "unknown grid scheme 'db99'; known: " + joined(aniso::grid_scheme_registry().names()));
  CHECK_THAT(message_of([] { law_traits("nope"); }), Contains("unknown law 'nope'"));
  CHECK_THROWS_WITH(register_law({"binomial", "again", [](const LawParams&) { return make_law("poisson"); }}),
                    "law registered twice: binomial");
  CHECK(make_law("binomial")->name() == "binomial");  // the original entry is untouched
}

// ---------------------------------------------------------------------------------------------
// Traits: what every declared law promises, checked on a grid of (n, p, u) in every precision the
// law supports.

namespace {

// n values exact in float, so that a float32 evaluation sees the same n as the bound.
const std::vector<double> kGridN{0.0,  0.25, 0.5,   1.0,    1.5,     2.0,       3.75,        10.5,
                                 16.0, 17.0, 100.0, 1000.0, 65536.0, 1048576.0, 1073741824.0};
const std::vector<double> kGridP{0.0, 1e-300, 1e-7, 0.05, 0.3, 0.5, 0.7, 1 - 1e-7, 1.0};

// Rows of k uniforms: the corners (0, 1 and near them, where quantiles run off to infinity) in every
// combination for the first two uniforms (a gate open with a Gaussian at its top is where counts
// overshoot), and ordinary draws.
std::vector<std::vector<double>> uniform_rows(int k) {
  const auto kk = static_cast<std::size_t>(std::max(k, 1));
  const std::vector<double> corners{0.0, 1e-12, 0.5, 1 - 1e-12, 1.0};
  std::vector<std::vector<double>> rows;
  for (double v : corners) {
    for (double w : corners) {
      std::vector<double> row(kk, w);
      row[0] = v;
      rows.push_back(row);
      if (kk == 1) break;
    }
  }
  std::mt19937_64 gen(12345);
  std::uniform_real_distribution<double> unif(0.0, 1.0);
  for (int r = 0; r < 16; ++r) {
    std::vector<double> row(kk);
    for (double& u : row) u = unif(gen);
    rows.push_back(row);
  }
  return rows;
}

std::string params_text(const LawParams& params) {
  std::string s;
  for (const auto& [k, v] : params) {
    s += (s.empty() ? "" : ", ") + k + "=";
    if (const double* x = std::get_if<double>(&v))
      s += std::to_string(*x);
    else
      s += std::get<std::string>(v);
  }
  return "{" + s + "}";
}

void check_declared_traits(const LawInfo& info) {
  INFO("law " << info.name);
  const LawTraits& t = info.traits;
  REQUIRE(t.declared());
  CHECK_FALSE(t.cost.empty());
  // Every declared law is covered by the generic tests, with its defaults among the variants.
  REQUIRE_FALSE(t.test_variants.empty());
  // Every variant a study, benchmark or bound names must construct.
  for (const auto* list : {&t.study_variants, &t.bench_variants, &t.test_variants})
    for (const auto& params : *list) CHECK_NOTHROW(make_law(info.name, params));
  const auto metric_list = metric_names();
  for (const auto& b : t.bounds) {
    INFO("bound " << b.reason);
    CHECK_NOTHROW(make_law(info.name, b.params));
    CHECK_FALSE(b.metrics.empty());
    CHECK_FALSE(b.reason.empty());
    for (const auto& m : b.metrics)
      CHECK((std::find(metric_list.begin(), metric_list.end(), m) != metric_list.end() || m == "mean_rel_err" ||
             m == "var_rel_err"));
    for (const auto& [key, range] : b.regime) {
      CHECK((key == "p_range" || key == "n_range" || key == "np_range"));
      CHECK(range[0] <= range[1]);
    }
  }
  if (t.support == SupportBound::kUnbounded) {
    CHECK(std::isinf(t.max_count(3.0)));
    CHECK_FALSE(t.support_note.empty());  // the exemption says why
  }
  if (t.support == SupportBound::kNPlusOne) CHECK_FALSE(t.support_note.empty());

  for (const auto& params : t.test_variants) {
    INFO("params " << params_text(params));
    const auto law = make_law(info.name, params);
    if (t.output == LawOutput::kInteger) CHECK(law->binning() == "none");
    if (t.reference) CHECK(law->has_pmf());
    const auto rows = uniform_rows(law->n_uniforms());
    for (const Precision prec : {Precision::kFloat64, Precision::kFloat32}) {
      if (!law->supports(prec)) continue;
      INFO("precision " << precision_name(prec));
      int bad_value = 0, not_integer = 0, above = 0;
      for (double n : kGridN) {
        for (double p : kGridP) {
          if (!law->accepts(n, p)) continue;
          const double w = law->work_units(n, p);
          if (!(w >= 0 && std::isfinite(w))) ++bad_value;
          if (t.constant_time && w != 0) ++bad_value;
          const double top = t.max_count(n);
          for (const auto& u : rows) {
            const double k =
                prec == Precision::kFloat32 ? law->evaluate_f32(n, p, u.data()) : law->evaluate(n, p, u.data());
            if (!std::isfinite(k) || k < 0) {
              ++bad_value;
              UNSCOPED_INFO("bad K = " << k << " at n = " << n << ", p = " << p << ", u0 = " << u[0]);
            }
            if (t.output == LawOutput::kInteger && k != std::floor(k)) {
              ++not_integer;
              UNSCOPED_INFO("non-integer K = " << k << " at n = " << n << ", p = " << p << ", u0 = " << u[0]);
            }
            if (k > top) {
              ++above;
              UNSCOPED_INFO("K = " << k << " above " << top << " at n = " << n << ", p = " << p << ", u0 = " << u[0]);
            }
          }
        }
      }
      CHECK(bad_value == 0);
      CHECK(not_integer == 0);
      CHECK(above == 0);
    }
    // Cost points must separate the cost terms: the work units differ between them.
    if (!t.cost_points.empty()) {
      CHECK_FALSE(t.constant_time);
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const auto& [n, p] : t.cost_points) {
        lo = std::min(lo, law->work_units(n, p));
        hi = std::max(hi, law->work_units(n, p));
      }
      if (params.empty()) CHECK(hi > lo);
    }
  }
}

}  // namespace

TEST_CASE("every built-in law declares its traits, and keeps them on a grid of (n, p, u)", "[registry][traits]") {
  int declared = 0;
  for (const auto& info : registered_laws()) {
    // Plugin laws declare nothing (their defaults promise nothing); every law of core/laws does.
    bool plugin = false;
    for (const auto& loaded : loaded_plugins())
      plugin = plugin || std::find(loaded.laws.begin(), loaded.laws.end(), info.name) != loaded.laws.end();
    if (plugin) continue;
    check_declared_traits(info);
    ++declared;
  }
  CHECK(declared >= 10);
}

TEST_CASE("declared traits say what the lists in the studies said", "[registry][traits]") {
  // The facts the Python name lists held, now read from the laws (spot checks, one per list).
  CHECK(law_traits("poisson").support == SupportBound::kUnbounded);      // extremes: unbounded_laws()
  CHECK(law_traits("gated_shader").support == SupportBound::kNPlusOne);  // its n + 1 defect
  CHECK(law_traits("binomial").reference);
  CHECK(law_traits("poisson").study_variants.empty());       // not in the trade study
  CHECK(law_traits("gaussian").study_variants.size() == 2);  // floor and round
  CHECK(law_traits("gaussian").bench_variants.size() == 1);
  CHECK(law_traits("zk16").test_variants.size() == 2);        // cap = 4 too
  CHECK(law_traits("threshold").output == LawOutput::kReal);  // the mean n p
  CHECK(law_traits("head_cf").constant_time);
  CHECK_FALSE(law_traits("zk16").constant_time);
  CHECK(law_traits("zk16").max_count(10.5) == 11);
  CHECK(law_traits("gated_shader").max_count(10.5) == 12);
  CHECK(support_bound_name(SupportBound::kBoundedByN) == "bounded_by_n");
  CHECK(law_output_name(LawOutput::kInteger) == "integer");
}

TEST_CASE("zk16's work units are the trials its loop runs", "[registry][traits][zk16]") {
  // With every uniform 0, each trial of the loop succeeds (0 < p, and 0 < frac(n) p for the
  // fractional facet), so K counts exactly the trials evaluate ran: the cost model and the sampler
  // share their constants.
  for (const double cap : {16.0, 4.0}) {
    const auto law = make_law("zk16", {{"cap", cap}});
    std::vector<double> zeros(static_cast<std::size_t>(law->n_uniforms()), 0.0);
    for (double n : {0.0, 0.5, 1.0, 3.0, 3.5, 4.0, 4.5, 15.5, 16.0, 16.5, 40.0, 99.0}) {
      for (double p : {0.01, 0.05, 0.1}) {
        INFO("cap " << cap << " n " << n << " p " << p);
        if (n * p > 5) {
          CHECK(law->work_units(n, p) == 0);  // the Gaussian branch: constant time
          continue;
        }
        CHECK(law->work_units(n, p) == law->evaluate(n, p, zeros.data()));
        CHECK(law->work_units(n, p) == std::min(std::ceil(n), cap));
      }
    }
    CHECK(law->work_units(1e3, 0.5) == 0);
    CHECK(law->work_units(100, 0.05) == cap);  // n p = 5 is still the loop (the switch is n p > 5)
  }
  CHECK(make_law("zk16")->work_units(100, 0.05) == 16);
  CHECK(make_law("threshold")->work_units(1e3, 0.5) == 0);  // above T: the mean, no walk
  CHECK(make_law("threshold")->work_units(100, 0.1) == Approx(11));
  CHECK(make_law("gated")->work_units(1e6, 0.3) == 0);
}

// ---------------------------------------------------------------------------------------------
// Adding a law touches one file and its test: here a small law is defined, registered, used by the
// generic drivers and checks, and removed.

namespace {

// "all_or_none": every facet reflects together, K = floor(n) with probability p, else 0. Exact law:
// two points. Small enough to check by hand, real enough to run through every generic path. Written
// the one way a law is (detail::KernelLaw: its eval gives evaluate, float32 and the batch paths).
class AllOrNoneLaw final : public detail::KernelLaw<AllOrNoneLaw> {
 public:
  std::string name() const override { return "test_all_or_none"; }
  int n_uniforms() const override { return 1; }
  template <class T>
  T eval(T n, T p, const T* u) const {
    return u[0] < p ? std::floor(n) : T(0);
  }
  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t) const override {
    const double top = std::floor(n);
    if (top == 0 || p == 0) return Distribution({0.0}, {1.0});
    if (p == 1) return Distribution({top}, {1.0});
    return Distribution({0.0, top}, {1 - p, p});
  }
};

LawInfo all_or_none_info() {
  return {"test_all_or_none",
          "test law: all facets reflect together",
          [](const LawParams& params) -> std::unique_ptr<CountingLaw> {
            ParamReader("test_all_or_none", params).finish();
            return std::make_unique<AllOrNoneLaw>();
          },
          {.output = LawOutput::kInteger,
           .support = SupportBound::kBoundedByN,
           .constant_time = true,
           .regime = "nowhere: a test of the registry",
           .cost = "constant: one comparison",
           .test_variants = {LawParams{}},
           .bounds = {{.regime = {{"p_range", {0, 0}}}, .metrics = {"tv"}, .reason = "p = 0: K = 0 exactly"}}}};
}

}  // namespace

TEST_CASE("a law defined in a test is registered, works everywhere, and is removed", "[registry][law]") {
  const std::string name = "test_all_or_none";
  REQUIRE_FALSE(law_registry().contains(name));
  {
    LawRegistration registration(all_or_none_info());
    bool listed = false;
    for (const auto& info : registered_laws()) listed = listed || info.name == name;
    CHECK(listed);
    CHECK_THAT(message_of([] { make_law("nope"); }), Contains(name));  // among the known names

    const auto law = make_law(name);
    CHECK(law->name() == name);
    CHECK_THROWS_WITH(make_law(name, {{"cap", 3.0}}), Contains("unknown parameter 'cap'"));
    CHECK(law_traits(name).constant_time);

    // The generic drivers: sample_many in both precisions, matching the exact law (chi-square).
    const double n = 7.5, p = 0.3;
    std::vector<double> k(100000);
    for (const Precision prec : {Precision::kFloat64, Precision::kFloat32}) {
      sample_many(*law, {&n, 1}, {&p, 1}, k.size(), 42, k.data(), prec);
      const auto r = chi2_test(k.data(), k.size(), law->pmf(n, p, 1000));
      INFO(r.note);
      CHECK(r.pvalue > 1e-6);
    }
    // Per-pixel parameters and validation by name, as for a built-in law.
    const std::vector<double> ns{0.0, 3.0, 1e6}, ps{0.5, 1.0, 0.0};
    std::vector<double> out(3);
    sample_many(*law, {ns.data(), 3}, {ps.data(), 3}, 3, 1, out.data());
    CHECK(out[0] == 0);
    CHECK(out[1] == 3);
    CHECK(out[2] == 0);
    const double bad_p = 1.5;
    CHECK_THROWS_WITH(sample_many(*law, {&n, 1}, {&bad_p, 1}, 1, 1, out.data()), Contains("p = 1.5"));

    // The checks every declared law passes.
    check_declared_traits(law_registry().find(name));
  }
  CHECK_FALSE(law_registry().contains(name));
  for (const auto& info : registered_laws()) CHECK(info.name != name);
  CHECK_THAT(message_of([&] { make_law(name); }), Contains("unknown law 'test_all_or_none'"));
  CHECK_THAT(message_of([&] { make_law(name); }), !Contains(", test_all_or_none"));
}

TEST_CASE("plugin laws registered after static initialization declare nothing", "[registry][plugin]") {
  const auto names = load_plugin(GLINTLAB_EXAMPLE_PLUGIN);
  REQUIRE_FALSE(names.empty());
  for (const auto& name : names) {
    CHECK(law_registry().contains(name));
    const LawTraits t = law_traits(name);
    CHECK_FALSE(t.declared());
    CHECK(t.output == LawOutput::kReal);  // nothing promised
    CHECK(t.support == SupportBound::kUnbounded);
    CHECK(make_law(name)->work_units(16, 0.1) == 0);
  }
}

// ---------------------------------------------------------------------------------------------
// Blends and grid schemes declare what the studies needed from them.

TEST_CASE("blend rules declare their analytic variance ratio, and it holds", "[registry][blend]") {
  const double density = 1000, p = 0.3;
  const LevelLadder ladder(4, 1);
  auto blended = [&](const std::string& rule) {
    return BlendedLaw(make_blend(rule), InnerLaw::from_law(std::shared_ptr<const CountingLaw>(make_law("binomial"))),
                      ladder);
  };
  // ZK16's output blend at w = 1/2 (P = 2 A_lo with ratio 4): 0.625 (its file comment).
  CHECK(blended("zk16_linear").variance_ratio(2.0) == Approx(0.625));
  CHECK(blended("zk16_linear").variance_ratio(1.0) == Approx(1.0));  // on a level
  CHECK(blended("nearest").variance_ratio(2.0) == Approx(0.5));      // P / A_hi: the upper level
  CHECK(blended("distributed").variance_ratio(2.0) == 1.0);
  CHECK(std::isnan(blended("roulette").variance_ratio(2.0)));  // no closed form declared
  CHECK_THROWS_WITH(blended("zk16_linear").variance_ratio(-1.0), Contains("P = -1"));

  // Measured: Var[K] / (N P p (1 - p)) from samples matches the declared ratio.
  for (const std::string rule : {"zk16_linear", "nearest", "distributed"}) {
    for (const double area : {1.5, 2.0, 3.0}) {
      INFO(rule << " P = " << area);
      const auto law = blended(rule);
      std::vector<double> k(40000);
      law.sample(density, {&area, 1}, {&p, 1}, k.size(), 7, k.data());
      double mean = 0, m2 = 0;
      for (double x : k) mean += x;
      mean /= static_cast<double>(k.size());
      for (double x : k) m2 += (x - mean) * (x - mean);
      const double var = m2 / static_cast<double>(k.size() - 1);
      const double ratio = var / (density * area * p * (1 - p));
      // Relative standard error of a variance from 4e4 draws: sqrt(2 / 4e4) = 0.7%; allow 5 sigma
      // (the ratios told apart here differ by 25% or more).
      CHECK(ratio == Approx(law.variance_ratio(area)).epsilon(0.035));
    }
  }
}

TEST_CASE("grid schemes declare the law they are counted with", "[registry][aniso]") {
  for (const auto& info : aniso::registered_grid_schemes()) {
    INFO(info.name);
    REQUIRE_FALSE(info.traits.native_law.empty());
    CHECK(law_registry().contains(info.traits.native_law));
  }
  CHECK(aniso::grid_scheme_registry().find("zk16_aniso").traits.native_law == "zk16");
  CHECK(aniso::grid_scheme_registry().find("db23_tetrahedral").traits.native_law == "gated");
}
