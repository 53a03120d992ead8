// Law "zk16": Zirr & Kaplanyan's hybrid as DB23 eq. 15 describes it.
//   n p > 5:  K = clamp(floor(n p + sqrt(n p (1 - p)) Phi^-1(theta0)), 0, ceil(n))
//   else:     K = sum of min(floor(n), cap) Bernoulli trials [theta_k < p], plus, when floor(n) < cap
//             and n is not an integer, the stratified rule's fractional facet [theta_m < frac(n) p].
// DB23 prints H(theta_k - p), which counts failures; the intent is theta_k < p (mean n p). The loop
// is capped at `cap` trials (default 16, DB23's "up to N = 16"; 1..64): for n > cap and n p <= 5 the
// law is Binomial(cap, p), whose mean cap p falls short of n p; that is the cap's measured effect.
// Cost grows with min(n, cap) below the switch: the point of DB23's constant-time law.
//
// Exact law: the Gaussian branch's is normal::discretized (floor); the loop's is the (stratified)
// binomial of min(n, cap) trials (n itself when floor(n) < cap).
#include <algorithm>
#include <cmath>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/normal.hpp"

namespace glintlab {
namespace {

// The law's constants, shared by the sampler, the exact pmf, the cost model and the declared
// traits (bound domains, cost points), so that none of them can drift from the others.
constexpr double kGaussianSwitch = 5.0;  // DB23 eq. 15: the Gaussian branch for n p > 5
constexpr int kDefaultCap = 16;          // DB23's "up to N = 16" Bernoulli trials

class Zk16Law final : public detail::KernelLaw<Zk16Law> {
 public:
  explicit Zk16Law(int cap) : cap_(cap) {}
  std::string name() const override { return "zk16"; }
  LawParams params() const override { return {{"cap", static_cast<double>(cap_)}}; }
  int n_uniforms() const override { return cap_; }

  template <class T>
  static bool gaussian_branch(T n, T p) {
    return n * p > T(kGaussianSwitch);
  }
  // The Bernoulli loop below the switch: `whole` trials [theta < p], plus the stratified rule's
  // fractional facet when the cap did not cut the loop and n is not an integer.
  struct Loop {
    int whole;
    bool fractional;
  };
  template <class T>
  Loop loop(T n) const {
    const T whole = std::floor(n);
    const int trials = whole < T(cap_) ? static_cast<int>(whole) : cap_;
    return {trials, trials < cap_ && n > whole};
  }

  template <class T>
  T eval(T n, T p, const T* u) const {
    if (gaussian_branch(n, p)) {
      const T mean = n * p;
      const T sd = std::sqrt(mean * (T(1) - p));
      const T g = sd > T(0) ? mean + sd * normal::quantile(u[0]) : mean;
      const T k = std::floor(g), top = std::ceil(n);
      return k < T(0) ? T(0) : (k > top ? top : k);
    }
    const Loop l = loop(n);
    T k = 0;
    for (int i = 0; i < l.whole; ++i) k += u[i] < p ? T(1) : T(0);
    if (l.fractional) k += u[l.whole] < (n - std::floor(n)) * p ? T(1) : T(0);
    return k;
  }

  // Trials of the explicit loop: what a shader pays per evaluation on top of the fixed cost (the
  // Gaussian branch is constant time: 0).
  double work_units(double n, double p) const override {
    if (gaussian_branch(n, p)) return 0.0;
    const Loop l = loop(n);
    return l.whole + (l.fractional ? 1.0 : 0.0);
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const double mean = n * p;
    if (gaussian_branch(n, p) && p == 1) {  // sd = 0: evaluate's G is the mean itself, a point mass
      const std::vector<double> k{std::clamp(std::floor(mean), 0.0, std::ceil(n))};
      return Distribution(k, {1.0});
    }
    if (gaussian_branch(n, p)) {
      auto law = normal::discretized(mean, std::sqrt(mean * (1 - p)), std::ceil(n), 0.0, max_support, "zk16.pmf");
      return Distribution::with_trimmed_tails(std::move(law.support), std::move(law.probs), law.trimmed_below,
                                              law.trimmed_above);
    }
    const double trials = std::floor(n) < cap_ ? n : static_cast<double>(cap_);
    return binomial::distribution(trials, p, max_support);
  }

 private:
  int cap_;
};

const bool registered =
    register_law({"zk16",
                  "ZK16 hybrid (DB23 eq. 15): Gaussian if n p > 5, else Bernoulli loop capped at cap=16",
                  [](const LawParams& params) -> std::unique_ptr<CountingLaw> {
                    ParamReader reader("zk16", params);
                    const double cap = reader.number("cap", kDefaultCap);
                    reader.finish();
                    if (!(cap >= 1 && cap <= detail::kMaxLawUniforms && cap == std::floor(cap)))
                      throw_invalid("law 'zk16'", "cap", cap, "an integer in [1, 64]");
                    return std::make_unique<Zk16Law>(static_cast<int>(cap));
                  },
                  {.output = LawOutput::kInteger,
                   .support = SupportBound::kBoundedByN,
                   .constant_time = false,
                   .regime = "n p > 5 (its Gaussian branch) or n <= cap (its Bernoulli loop is then exact)",
                   .cost = "constant on the Gaussian branch; below it, work_units = min(ceil n, cap) Bernoulli trials",
                   .study_variants = {LawParams{}},
                   .bench_variants = {LawParams{}},
                   // cap = 4: a cap that cuts the loop inside the test points (n between 4 and 16).
                   .test_variants = {LawParams{}, LawParams{{"cap", 4.0}}},
                   // The loop at cap trials and at 1 trial (their difference is the cost of cap - 1 trials), and
                   // the Gaussian branch: p chosen so that n p stays below or above the switch.
                   .cost_points = {{kDefaultCap, 0.05}, {1.0, 0.05}, {1e3, 0.5}},
                   .bounds = {{.regime = {{"p_range", {0, 0.5}}, {"np_range", {10, 1e300}}},
                               .metrics = {"tv", "mean_rel_err"},
                               .reason = "the Gaussian branch (n p > 5)"},
                              {.regime = {{"n_range", {0, kDefaultCap}}, {"np_range", {0, kGaussianSwitch}}},
                               .metrics = {"tv", "mean_rel_err"},
                               .reason = "n p <= 5 and n <= cap: the Bernoulli loop is exact"}}}});

}  // namespace
}  // namespace glintlab
