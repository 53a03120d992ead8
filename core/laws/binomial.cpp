// Law "binomial": the exact reference, K ~ Binomial(n, p) (non-integer n by the stratified rule of
// binomial.hpp). evaluate() inverts the exact CDF with one uniform (monotone in u, so neighbouring
// u give neighbouring K: useful for coherence studies); sample() uses the BTRD/inversion sampler,
// which is 10-100x cheaper than CDF inversion for large n.
#include "glintlab/stats/binomial.hpp"

#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"

#include <algorithm>
#include <memory>
#include <utility>

namespace glintlab {
namespace {

// Its own kernel: the fixed evaluator's table, and its own sampler (BTRD / inversion, not evaluate()).
class BinomialLaw final : public detail::KernelLaw<BinomialLaw> {
 public:
  std::string name() const override { return "binomial"; }
  int n_uniforms() const override { return 1; }
  // float64 only (an eval of doubles, not a template).
  double eval(double n, double p, const double* u) const { return binomial::quantile(u[0], n, p); }
  // Many rows at one (n, p) on given uniforms (a blend's level at one footprint area): quantile on a
  // table of the distribution functions it compares against (binomial::QuantileTable), bit for bit.
  std::unique_ptr<detail::FixedEvaluator> fixed_evaluator(double n, double p, std::size_t rows) const override {
    auto table = std::make_shared<const binomial::QuantileTable>(n, p, rows);
    if (!table->tabulated()) return KernelLaw::fixed_evaluator(n, p, rows);
    return detail::make_fixed_evaluator([table](const double* u, std::size_t count, double* out) {
      for (std::size_t r = 0; r < count; ++r) out[r] = (*table)(u[r]);
    });
  }
  bool samples_by_evaluate() const override { return false; }
  // Sample i's first Philox block (two uniforms: all that most draws use) comes from the vectorized
  // rows, the rest from its scalar generator (PrefetchedRng): the same numbers as before. The
  // sampler's common first step runs across the rows as vector code (Sampler::sample_rows).
  void sample_range(double n, double p, std::uint64_t seed, std::size_t i0, std::size_t i1,
                    double* out) const override {
    sample_with(binomial::Sampler(n, p, /*tabulate=*/i1 - i0 >= kTabulateMinBatch), seed, i0, i1, out);
  }
  // Long batches: one sampler for the whole call (shared by the threads), with BTRD's final test
  // values tabulated when the batch is at least 16 times longer than the table.
  std::unique_ptr<detail::BatchSampler> batch_sampler(double n, double p, std::size_t count) const override {
    binomial::Sampler sampler(n, p, /*tabulate=*/true);
    sampler.tabulate_log_ratios(count / 16);
    return std::make_unique<Batch>(std::move(sampler));
  }
  // Pixels: the same prefetched rows; the per-pixel setup and first steps as vector code
  // (binomial::sample_pixels), a scalar sampler per (n, p) (no table) for the rest.
  void sample_pixels(const double* n, const double* p, std::uint64_t seed, std::size_t start, std::size_t count,
                     double* out) const override {
    alignas(64) double u[2 * kRows];
    for (std::size_t b = 0; b < count; b += kRows) {
      const std::size_t rows = std::min(kRows, count - b);
      detail::philox_uniform_rows(seed, kStreamSample, start + b, rows, 2, u);
      binomial::sample_pixels(n + b, p + b, u, seed, start + b, kStreamSample, rows, out + b);
    }
  }

 private:
  static constexpr std::size_t kRows = 256;

  static void sample_with(const binomial::Sampler& sampler, std::uint64_t seed, std::size_t i0, std::size_t i1,
                          double* out) {
    alignas(64) double u[2 * kRows];
    for (std::size_t b = i0; b < i1; b += kRows) {
      const std::size_t rows = std::min(kRows, i1 - b);
      detail::philox_uniform_rows(seed, kStreamSample, b, rows, 2, u);
      sampler.sample_rows(u, seed, b, kStreamSample, rows, out + (b - i0));
    }
  }

  class Batch final : public detail::BatchSampler {
   public:
    explicit Batch(binomial::Sampler sampler) : sampler_(std::move(sampler)) {}
    void sample_range(std::uint64_t seed, std::size_t i0, std::size_t i1, double* out) const override {
      sample_with(sampler_, seed, i0, i1, out);
    }

   private:
    binomial::Sampler sampler_;
  };

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
