// Law "dual_gated": Kneiphof & Klein's dual-gated Gaussian (KK25, "Real-time Image-based Lighting of
// Glints", CGF 44(4) 2025, arXiv 2507.02674, §4), as defined by the paper and its public demo shader.
// One uniform theta0 gates *both* extreme outcomes, so that p -> 1 behaves like p -> 0:
//
//   n >= 2:  K = n                                   if theta0 < p^n           (every facet reflects)
//            K = 0                                   if theta0 >= 1 - (1-p)^n  (none does)
//            K = clamp(1 + (n-2)p + sd z, 1, n - 1)  otherwise, sd^2 = (n-2) p (1-p), z = Phi^-1(theta1)
//   The central part is the normal approximation of 1 + Binomial(n - 2, p): one facet that reflects,
//   one that does not, and a binomial on the n - 2 others (mean 1 + (n - 2) p, variance (n - 2) p q).
//   It stands in for the binomial conditioned on 1 <= K <= n - 1 but is not that law's moment match:
//   the two agree for n <= 3 only (n = 4, p = 0.1: central mean 1.2, conditional mean 1.1623). This
//   is the law of KK25's construction and of the shipped shaders (data/shaders/dual_gated.*), so the
//   sampler, the exact pmf below and docs/math/laws.md#law-dual-gated all use 1 + (n - 2) p.
//
//   n < 2 (their continuous extension, a mixture that is exact at n = 1 and n = 2):
//            weight s = clamp(n - 1, 0, 1) on two facets and t = max(0, 1 - |1 - n|) on one:
//            K = 2 with probability s p^2, K = 1 with probability t p + s 2p(1-p), else K = 0;
//            for n <= 1 this is Bernoulli(n p) (mean n p, like "gated_continuous").
//   The uniform is split in the shader's order: [0, s p^2) -> all reflect, then t p -> exactly one
//   reflects, the top s (1-p)^2 + t (1-p) -> none, and the rest is the central Gaussian (clamped to 1
//   when n < 2, where sd = 0).
//
// Gates are hard (KK25's smoothing width is a renderer setting; glintlab measures the soft ramp on
// "gated_shader"). The shader's flip for p > 1/2 (evaluate with 1 - p and swap) only buys float
// precision: here p^n and (1-p)^n are both formed as exp(n log p), exp(n log1p(-p)), and the flip
// would not change the law.
//
// Binning: round-half-up, unit bins [k - 1/2, k + 1/2) (the central part and K = n are real).
// Exact law: the atoms above plus the central Gaussian rounded and clamped (normal CDFs), since
// round(clamp(G, 1, n - 1)) = clamp(round(G), 1, round(n - 1)).
#include <algorithm>
#include <cmath>

#include "glintlab/base/errors.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/normal.hpp"

namespace glintlab {
namespace {

// The partition of theta0 in [0, 1): [0, all) -> K = top, [all, one) -> K = 1, [none, 1) -> K = 0,
// [one, none) -> central.
template <class T>
struct Gates {
  T all, one, none, top;
  Gates(T n, T p) {
    if (n >= T(2)) {
      all = std::exp(n * std::log(p));  // p^n (0 at p = 0: log 0 = -inf)
      one = all;
      none = -std::expm1(n * std::log1p(-p));  // 1 - (1-p)^n without cancellation
      top = n;
    } else {
      const T s = n > T(1) ? n - T(1) : T(0);
      const T t = n > T(1) ? T(2) - n : n;
      all = s * p * p;
      one = all + t * p;
      none = T(1) - (s * (T(1) - p) * (T(1) - p) + t * (T(1) - p));
      top = T(2);
    }
  }
};

class DualGatedLaw final : public detail::KernelLaw<DualGatedLaw> {
 public:
  std::string name() const override { return "dual_gated"; }
  int n_uniforms() const override { return 2; }

  // The per-(n, p) constants (gates, central Gaussian), computed once per batch (detail::KernelLaw:
  // eval is Constants(n, p)(u)).
  template <class T>
  struct Constants {
    Gates<T> g;
    T n, a, s;
    Constants(T n_, T p) : g(n_, p), n(n_) {
      const T var = (n - T(2)) * p * (T(1) - p);
      a = T(1) + (n - T(2)) * p;
      s = var > T(0) ? std::sqrt(var) : T(0);
    }
    T operator()(const T* u) const {
      const T theta0 = u[0];
      if (theta0 < g.all) return g.top;
      if (theta0 < g.one) return T(1);
      if (!(theta0 < g.none) || n <= T(1)) return T(0);
      if (n < T(2)) return T(1);
      const T x = a + (s > T(0) ? s * normal::quantile(u[1]) : T(0));
      const T hi = n - T(1);
      return x < T(1) ? T(1) : (x > hi ? hi : x);  // also maps x = +-inf to the ends
    }
  };

  template <class T>
  Constants<T> constants(T n, T p) const {
    return Constants<T>(n, p);
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const Gates<double> g(n, p);
    const double central = n <= 1 ? 0.0 : std::max(0.0, g.none - g.one);
    std::vector<std::pair<double, double>> atoms{
        {0.0, n <= 1 ? 1 - g.one : 1 - g.none}, {1.0, g.one - g.all}, {std::floor(g.top + 0.5), g.all}};
    // Mass trimmed from the central Gaussian's tails (< 1e-16 a side) lies between atoms: no flag.
    if (central > 0) {
      const double var = n > 2 ? (n - 2) * p * (1 - p) : 0.0;
      const double hi = std::floor(std::max(1.0, n - 1) + 0.5);  // round(n - 1)
      if (var > 0) {
        const auto law = normal::discretized((n - 2) * p, std::sqrt(var), hi - 1, 0.5, max_support, "dual_gated.pmf");
        for (std::size_t i = 0; i < law.support.size(); ++i)
          atoms.emplace_back(1 + law.support[i], central * law.probs[i]);
      } else {
        atoms.emplace_back(std::clamp(std::floor(1 + std::max(0.0, n - 2) * p + 0.5), 1.0, hi), central);
      }
    }
    std::sort(atoms.begin(), atoms.end());
    std::vector<double> ks, ps;
    for (const auto& [k, q] : atoms) {
      if (!(q > 0)) continue;
      if (!ks.empty() && ks.back() == k) {
        ps.back() += q;
      } else {
        ks.push_back(k);
        ps.push_back(q);
      }
    }
    if (ks.size() > max_support)
      throw_invalid("dual_gated.pmf", "max_support", static_cast<double>(max_support), "a larger value");
    return Distribution::with_trimmed_tails(std::move(ks), std::move(ps), false, false);
  }
};

const bool registered = register_parameterless_law<DualGatedLaw>(
    "dual_gated", "KK25 dual-gated Gaussian: one uniform gates K = 0 and K = n, Gaussian on the n-2 others",
    {.output = LawOutput::kReal,  // the central Gaussian is not floored
     .support = SupportBound::kBoundedByN,
     .constant_time = true,
     .regime = "the whole (n, p) plane: the second gate fixes the gated Gaussian's p -> 1 failure",
     .cost = "constant: two exp/log pairs, sqrt and one Phi^-1",
     .study_variants = {LawParams{}},
     .bench_variants = {LawParams{}},
     .test_variants = {LawParams{}},
     .bounds = {{.regime = {{"p_range", {0, 0.5}}}, .metrics = {"tv", "mean_rel_err"}, .reason = "KK25, p <= 1/2"},
                {.metrics = {"tv"}, .reason = "KK25 over the whole grid (fixes the gate's p -> 1 failure)"}},
     .shader = "dual_gated"});

}  // namespace
}  // namespace glintlab
