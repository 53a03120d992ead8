// Law "poisson": the count of a Poisson facet layout of intensity N in a footprint holding n = N P
// facets on average, K ~ Poisson(n p) (docs/math/ground_truth.md#gt-poisson). Any real n >= 0 is natural here.
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"

namespace glintlab {
namespace {

// Its own kernel: its own sampler (poisson::Sampler on the sample's stream, not evaluate()).
class PoissonLaw final : public detail::KernelLaw<PoissonLaw> {
 public:
  std::string name() const override { return "poisson"; }
  int n_uniforms() const override { return 1; }
  // float64 only (an eval of doubles, not a template).
  double eval(double n, double p, const double* u) const { return poisson::quantile(u[0], n * p); }
  bool samples_by_evaluate() const override { return false; }
  void sample_range(double n, double p, std::uint64_t seed, std::size_t i0, std::size_t i1,
                    double* out) const override {
    const poisson::Sampler sampler(n * p, /*tabulate=*/i1 - i0 >= kTabulateMinBatch);
    for (std::size_t i = i0; i < i1; ++i) {
      auto rng = CounterRng::for_index(seed, i, kStreamSample);
      out[i - i0] = sampler(rng);
    }
  }
  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    return poisson::distribution(n * p, max_support);
  }
};

const bool registered = register_parameterless_law<PoissonLaw>(
    "poisson", "exact Poisson(n p): the count of a Poisson facet layout",
    {.output = LawOutput::kInteger,
     .support = SupportBound::kUnbounded,
     .support_note = "the Poisson layout: K ~ Poisson(n p) counts a Poisson number of facets",
     .constant_time = false,
     .reference = true,
     .regime = "a Poisson facet layout; as an approximation of the binomial, small p (its limit)",
     .cost = "evaluate() searches the exact CDF (grows slowly with n p); work_units does not model it (0)",
     // Another facet model, not an approximation of the binomial: not in the trade study or the
     // benchmark (both compare approximations with the binomial).
     .test_variants = {LawParams{}},
     .bounds = {{.regime = {{"p_range", {0, 1e-3}}},
                 .metrics = {"tv", "mean_rel_err"},
                 .reason = "the Poisson layout is the small-p limit"}}});

}  // namespace
}  // namespace glintlab
