// Law "poisson": the count of a Poisson facet layout of intensity N in a footprint holding n = N P
// facets on average, K ~ Poisson(n p) (LAWS.md §2). Any real n >= 0 is natural here.
#include "glintlab/binomial.hpp"
#include "glintlab/law.hpp"

namespace glintlab {
namespace {

class PoissonLaw final : public CountingLaw {
 public:
  std::string name() const override { return "poisson"; }
  int n_uniforms() const override { return 1; }
  double evaluate(double n, double p, const double* u) const override {
    return poisson::quantile(u[0], n * p);
  }
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
    "poisson", "exact Poisson(n p): the count of a Poisson facet layout");

}  // namespace
}  // namespace glintlab
