// Law "binomial": the exact reference, K ~ Binomial(n, p) (non-integer n by the stratified rule of
// binomial.hpp). evaluate() inverts the exact CDF with one uniform (monotone in u, so neighbouring
// u give neighbouring K: useful for coherence studies); sample() uses the BTRD/inversion sampler,
// which is 10-100x cheaper than CDF inversion for large n.
#include "glintlab/binomial.hpp"

#include "glintlab/law.hpp"

#include <algorithm>
#include <memory>

namespace glintlab {
namespace {

class BinomialLaw final : public CountingLaw {
 public:
  std::string name() const override { return "binomial"; }
  int n_uniforms() const override { return 1; }
  double evaluate(double n, double p, const double* u) const override {
    return binomial::quantile(u[0], n, p);
  }
  // Many rows at one (n, p) on given uniforms (a blend's level at one footprint area): quantile on a
  // table of the distribution functions it compares against (binomial::QuantileTable), bit for bit.
  std::unique_ptr<FixedEvaluator> fixed_evaluator(double n, double p, std::size_t rows) const override {
    auto table = std::make_shared<const binomial::QuantileTable>(n, p, rows);
    if (!table->tabulated()) return CountingLaw::fixed_evaluator(n, p, rows);
    return make_fixed_evaluator([table](const double* u, std::size_t count, double* out) {
      for (std::size_t r = 0; r < count; ++r) out[r] = (*table)(u[r]);
    });
  }
  bool samples_by_evaluate() const override { return false; }
  // Sample i's first Philox block (two uniforms: all that most draws use) comes from the vectorized
  // rows, the rest from its scalar generator (PrefetchedRng): the same numbers as before.
  void sample_range(double n, double p, std::uint64_t seed, std::size_t i0, std::size_t i1,
                    double* out) const override {
    const binomial::Sampler sampler(n, p, /*tabulate=*/i1 - i0 >= kTabulateMinBatch);
    alignas(64) double u[2 * kRows];
    for (std::size_t b = i0; b < i1; b += kRows) {
      const std::size_t rows = std::min(kRows, i1 - b);
      detail::philox_uniform_rows(seed, kStreamSample, b, rows, 2, u);
      for (std::size_t r = 0; r < rows; ++r) {
        binomial::PrefetchedRng rng(u + 2 * r, seed, b + r, kStreamSample);
        out[b - i0 + r] = sampler(rng);
      }
    }
  }
  // Pixels: a sampler per (n, p) (no table), the same prefetched rows.
  void sample_pixels(const double* n, const double* p, std::uint64_t seed, std::size_t start, std::size_t count,
                     double* out) const override {
    alignas(64) double u[2 * kRows];
    for (std::size_t b = 0; b < count; b += kRows) {
      const std::size_t rows = std::min(kRows, count - b);
      detail::philox_uniform_rows(seed, kStreamSample, start + b, rows, 2, u);
      for (std::size_t r = 0; r < rows; ++r) {
        const binomial::Sampler sampler(n[b + r], p[b + r]);
        binomial::PrefetchedRng rng(u + 2 * r, seed, start + b + r, kStreamSample);
        out[b + r] = sampler(rng);
      }
    }
  }

 private:
  static constexpr std::size_t kRows = 256;

 public:
  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    return binomial::distribution(n, p, max_support);
  }
};

const bool registered = register_parameterless_law<BinomialLaw>(
    "binomial", "exact Binomial(n, p); non-integer n = Binomial(floor n, p) + Bernoulli(frac(n) p)",
    {.output = LawOutput::kInteger,
     .support = SupportBound::kBoundedByN,
     .constant_time = false,
     .reference = true,
     .regime = "everywhere: the exact reference every approximation is measured against",
     .cost = "evaluate() searches the exact CDF (grows slowly with the spread); sample() has bounded "
             "expected cost; work_units does not model either (0)",
     .study_variants = {LawParams{}},
     .bench_variants = {LawParams{}},
     .test_variants = {LawParams{}},
     .bounds = {{.metrics = {"tv", "mean_rel_err"}, .reason = "the exact law against itself: rounding only"}}});

}  // namespace
}  // namespace glintlab
