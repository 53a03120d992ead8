// Law "gated_continuous": Kneiphof & Klein's continuous gated Gaussian (KK24; docs/math/laws.md#law-gated-continuous),
// the form DB23's gate takes in their area-light renderer:
//   m = max(n, 1);  P1 = 1 - (1 - p)^n for n >= 1 (as -expm1(n log1p(-p))), P1 = n p for n < 1
//   (a gate that stays continuous at n = 1 and keeps E[K] = n p for a sub-facet footprint);
//   G = 1 + (m - 1) p + sqrt((m - 1) p (1 - p)) Phi^-1(theta1)   (no floor: the output is real)
//   K = [theta0 < P1] clamp(G, 1, m).
// The gate is hard (theta0 < P1), a policy stated in docs/math/laws.md#law-gated-continuous; the soft ramp of the
// public shaders is measured on "gated_shader".
//
// Binning: pmf() and law.bin() use round-half-up, unit bins [k - 1/2, k + 1/2). Since rounding is
// monotone, round(clamp(G, 1, m)) = clamp(round(G), 1, round(m)), so the binned law is exact
// through normal CDFs: P(K = 0) = 1 - P1 and, for k >= 1,
//   P(round K = k) = P1 P(clamp(floor(G + 1/2), 1, floor(m + 1/2)) = k).
#include <algorithm>
#include <cmath>

#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/normal.hpp"

namespace glintlab {
namespace {

class GatedContinuousLaw final : public detail::KernelLaw<GatedContinuousLaw> {
 public:
  std::string name() const override { return "gated_continuous"; }
  int n_uniforms() const override { return 2; }

  template <class T>
  static T gate_probability(T n, T p) {
    return n < T(1) ? n * p : -std::expm1(n * std::log1p(-p));
  }

  // The per-(n, p) constants, so that a batch computes them once (detail::KernelLaw: eval is
  // Constants(n, p)(u)).
  template <class T>
  struct Constants {
    T p1, m, a, s;
    Constants(T n, T p) : p1(gate_probability(n, p)), m(n > T(1) ? n : T(1)) {
      const T var = (m - T(1)) * p * (T(1) - p);
      a = T(1) + (m - T(1)) * p;
      s = var > T(0) ? std::sqrt(var) : T(0);
    }
    T operator()(const T* u) const {
      if (!(u[0] < p1)) return T(0);
      const T g = a + (s > T(0) ? s * normal::quantile(u[1]) : T(0));
      return g < T(1) ? T(1) : (g > m ? m : g);  // also maps g = +-inf (theta1 = 0 or 1) to the ends
    }
  };

  template <class T>
  Constants<T> constants(T n, T p) const {
    return Constants<T>(n, p);
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const double p1 = gate_probability(n, p);
    const double m = std::max(n, 1.0), var = (m - 1) * p * (1 - p);
    const double top = std::floor(m + 0.5);
    std::vector<double> ks, ps;
    if (p1 < 1) {
      ks.push_back(0);
      ps.push_back(1 - p1);
    }
    bool trimmed_above = false;  // (mass trimmed between 0 and the Gaussian part is < 1e-16)
    if (p1 > 0) {
      if (var > 0) {
        // K - 1 = clamp(floor((G - 1) + 1/2), 0, top - 1).
        const auto law =
            normal::discretized((m - 1) * p, std::sqrt(var), top - 1, 0.5, max_support, "gated_continuous.pmf");
        for (std::size_t i = 0; i < law.support.size(); ++i) {
          ks.push_back(1 + law.support[i]);
          ps.push_back(p1 * law.probs[i]);
        }
        trimmed_above = law.trimmed_above;
      } else {
        ks.push_back(std::clamp(std::floor(1 + (m - 1) * p + 0.5), 1.0, top));
        ps.push_back(p1);
      }
    }
    return Distribution::with_trimmed_tails(std::move(ks), std::move(ps), false, trimmed_above);
  }
};

const bool registered = register_parameterless_law<GatedContinuousLaw>(
    "gated_continuous", "KK24 continuous gated Gaussian: K = [theta0 < P1] clamp(1 + (m-1)p + sd z, 1, max(n,1))",
    {.output = LawOutput::kReal,  // no floor: G is real
     .support = SupportBound::kBoundedByN,
     .constant_time = true,
     .regime = "p <= 1/2 (KK24's area-light renderer); continuous in n, also below one facet",
     .cost = "constant: exp, log1p, sqrt and one Phi^-1",
     .study_variants = {LawParams{}},
     .bench_variants = {LawParams{}},
     .test_variants = {LawParams{}},
     .bounds = {{.regime = {{"p_range", {0, 0.5}}}, .metrics = {"tv", "mean_rel_err"}, .reason = "KK24, p <= 1/2"}},
     .shader = "gated_continuous"});

}  // namespace
}  // namespace glintlab
