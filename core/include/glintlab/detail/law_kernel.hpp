// A law's fast paths: the one optional interface behind CountingLaw (law.hpp), internal to the
// library. A law is defined by evaluate() (and its exact pmf); everything here is an optimization
// that must give, bit for bit, what evaluate() gives on the same uniforms (or, for a law with its
// own sampler, what its sample_range gives), never a different law. The drivers (sample_many, the
// blends) reach the paths through KernelOf, which falls back to evaluate() where a law has none.
//
// Two kinds of fast path:
//   - on given uniforms, bit for bit evaluate(): fixed_evaluator (many rows at one (n, p): a batch,
//     a blend's level at one footprint area) and evaluate_pixels (rows with their own (n, p): a
//     renderer's pixels). A law that samples by evaluate() on the fill_uniforms rows gets its batch
//     and per-pixel sampling from these two: nothing more to write.
//   - a law's own sampler (the exact laws: rejection, BTRD), where the samples are not evaluate() on
//     the fill_uniforms rows: samples_by_evaluate() is false and it overrides sample_range (and may
//     override batch_sampler and sample_pixels, the same samples faster).
//
// KernelLaw is the one way a law is written (core/laws/<name>.cpp): it is the CountingLaw and its
// own LawKernel, derives evaluate (and float32) from the law's eval, and the batch paths from its
// per-(n, p) constants where it has them; see its comment.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>

#include "glintlab/base/float32.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/uniform_rows.hpp"
#include "glintlab/stats/step_inversion.hpp"

namespace glintlab::detail {

// Per-(n, p) state for a long batch at one (n, p): hoisted constants and inversion tables, built
// once per sample_many() call and shared by its threads. sample_range gives exactly what the
// kernel's sample_range gives.
class BatchSampler {
 public:
  virtual ~BatchSampler() = default;
  virtual void sample_range(std::uint64_t seed, std::size_t i0, std::size_t i1, double* out) const = 0;
};

// Evaluations at one fixed (n, p) on rows of given uniforms, prepared once for many rows.
// evaluate() is const and may run on several threads at once.
class FixedEvaluator {
 public:
  virtual ~FixedEvaluator() = default;
  // out[r] = CountingLaw::evaluate(n, p, u + r * n_uniforms) for r < rows, bit for bit, for
  // uniforms in (0, 1) (those of fill_uniforms and CounterRng).
  virtual void evaluate(const double* u, std::size_t rows, double* out) const = 0;
};

// A BatchSampler that hands blocks of rows to f(const double* u, std::size_t rows, double* out):
// u holds `rows` rows of k uniforms (those of fill_uniforms), out gets one sample per row. Blocks
// let a law run vector code over many rows (a table lookup for all, then a select).
template <class F>
class BlockBatchSampler final : public BatchSampler {
 public:
  static constexpr std::size_t kRows = 256;
  BlockBatchSampler(int k, F f) : k_(k), f_(std::move(f)) {}
  void sample_range(std::uint64_t seed, std::size_t i0, std::size_t i1, double* out) const override {
    alignas(64) double u[kRows * 4];
    for (std::size_t b0 = i0; b0 < i1; b0 += kRows) {
      const std::size_t rows = std::min(kRows, i1 - b0);
      philox_uniform_rows(seed, kStreamSample, b0, rows, k_, u);
      f_(static_cast<const double*>(u), rows, out + (b0 - i0));
    }
  }

 private:
  int k_;
  F f_;
};

// Batch sampler from a block function f(u, rows, out) (see BlockBatchSampler), 1 to 4 uniforms.
template <class F>
std::unique_ptr<BatchSampler> make_block_batch_sampler(int k, F f) {
  if (k < 1 || k > 4) throw std::logic_error("make_block_batch_sampler: 1 to 4 uniforms");
  return std::make_unique<BlockBatchSampler<F>>(k, std::move(f));
}

// A FixedEvaluator from f(const double* u, std::size_t rows, double* out).
template <class F>
std::unique_ptr<FixedEvaluator> make_fixed_evaluator(F f) {
  struct Evaluator final : FixedEvaluator {
    explicit Evaluator(F g) : f(std::move(g)) {}
    void evaluate(const double* u, std::size_t rows, double* out) const override { f(u, rows, out); }
    F f;
  };
  return std::make_unique<Evaluator>(std::move(f));
}

// The fast paths of one law (see the header comment). The defaults are the law's definition:
// evaluate() row by row, and samples that are evaluate() on the fill_uniforms rows. A kernel refers
// to its law, which outlives it (a law that has a kernel is its own kernel: KernelLaw).
class LawKernel {
 public:
  explicit LawKernel(const CountingLaw& law) : law_(&law) {}
  virtual ~LawKernel() = default;
  LawKernel(const LawKernel&) = delete;
  LawKernel& operator=(const LawKernel&) = delete;

  // --- On given uniforms, bit for bit evaluate() (uniforms in (0, 1)). (n, p) already accepted.
  // About `rows` evaluations at one (n, p), prepared once (a law whose per-(n, p) table pays for
  // `rows` evaluations builds it here). Default: evaluate() per row.
  virtual std::unique_ptr<FixedEvaluator> fixed_evaluator(double n, double p, std::size_t rows) const;
  // `count` evaluations with their own (n, p) each: out[i] = evaluate(n[i], p[i], u + i * k).
  // Default: evaluate() per pixel; laws with costly per-(n, p) constants compute them with vector
  // code over the block and fall back to evaluate() wherever the vector result could decide
  // differently.
  virtual void evaluate_pixels(const double* n, const double* p, const double* u, std::size_t count, double* out) const;

  // --- Sampling. Sample i of a batch uses CounterRng::for_index(seed, i, kStreamSample), so results
  // do not depend on how a batch is split between threads.
  // Whether the samples are evaluate() on the fill_uniforms rows (everything below is then derived
  // from the two paths above). A law with its own sampler returns false and overrides sample_range.
  virtual bool samples_by_evaluate() const { return true; }
  // Samples i0 .. i1-1 at one (n, p).
  virtual void sample_range(double n, double p, std::uint64_t seed, std::size_t i0, std::size_t i1, double* out) const;
  // Samples start .. start + count - 1 whose (n, p) change at every sample: out[r] is what
  // sample_range(n[r], p[r], seed, start + r, start + r + 1) gives. Default: the uniforms' rows and
  // evaluate_pixels when sampling by evaluate, else sample_range per pixel.
  virtual void sample_pixels(const double* n, const double* p, std::uint64_t seed, std::size_t start, std::size_t count,
                             double* out) const;
  // A batch sampler for `count` (>= kTabulateMinBatch) samples at one (n, p), or nullptr (then
  // sample_range). Default: when sampling by evaluate with 1 to 4 uniforms, fixed_evaluator on
  // blocks of the fill_uniforms rows; else nullptr.
  virtual std::unique_ptr<BatchSampler> batch_sampler(double n, double p, std::size_t count) const;

 protected:
  const CountingLaw& law() const { return *law_; }

 private:
  const CountingLaw* law_;
};

// The kernel the drivers use for a law: its own, or the defaults (everything by evaluate()).
class KernelOf {
 public:
  explicit KernelOf(const CountingLaw& law) : fallback_(law), kernel_(law.kernel() ? law.kernel() : &fallback_) {}
  KernelOf(const KernelOf&) = delete;
  KernelOf& operator=(const KernelOf&) = delete;
  const LawKernel& operator*() const { return *kernel_; }
  const LawKernel* operator->() const { return kernel_; }

 private:
  LawKernel fallback_;
  const LawKernel* kernel_;
};

// A step table for many rows at one (n, p) (step_inversion.hpp): the value of uniform column `col`
// by table lookup, mapped by `f`; rows too close to a step go to evaluate().
struct RowTable {
  StepInversion steps;
  StepInversion::Affine f{};
  std::size_t col = 0;
};

// The largest n_uniforms() of a law evaluated in float32 by KernelLaw (its uniforms are converted on the
// stack).
inline constexpr int kMaxLawUniforms = 64;

// The one way to write a law: class MyLaw final : public detail::KernelLaw<MyLaw>, which is both the
// CountingLaw and its own LawKernel. MyLaw provides name() and n_uniforms(), and K from (n, p, u) as
//   template <class T> T eval(T n, T p, const T* u) const;   // float64 and float32 (a shader's view)
// or, for a law defined in float64 only (the exact laws),
//   double eval(double n, double p, const double* u) const;
// or only the constants below (eval is then constants(n, p)(u)). From eval KernelLaw derives
// evaluate(), evaluate_f32() (n, p rounded to float, the uniforms by float32.hpp's rule, as the shader
// runner feeds a shader) and supports(). Then, each only where it pays, all bit for bit eval:
//   template <class T> auto constants(T n, T p) const;  // c with T c(const T* u): the per-(n, p)
//       // constants computed once for a batch's rows (fixed_evaluator, hence the batch sampler)
//   std::optional<RowTable> table(double n, double p, std::size_t rows) const;  // a step table for
//       // batches of at least kTabulateMinBatch rows
//   evaluate_pixels (vector code over a block: detail/pixel_blocks.hpp), or an own sampler
//       // (samples_by_evaluate() false, sample_range, batch_sampler, sample_pixels): LawKernel's
//       // virtuals, overridden where the law has them
// and the definition's optional parts: has_pmf/pmf, params, work_units (CountingLaw).
template <class Derived>
class KernelLaw : public CountingLaw, public LawKernel {
 public:
  KernelLaw() : LawKernel(static_cast<const CountingLaw&>(*this)) {}
  const LawKernel* kernel() const final { return this; }

  double evaluate(double n, double p, const double* u) const override { return self().eval(n, p, u); }
  double evaluate_f32(double n, double p, const double* u) const override {
    if constexpr (has_float32()) {
      std::array<float, kMaxLawUniforms> uf{};
      for (int i = 0; i < this->n_uniforms(); ++i) uf[static_cast<std::size_t>(i)] = uniform_to_float(u[i]);
      return static_cast<double>(self().eval(static_cast<float>(n), static_cast<float>(p), uf.data()));
    } else {
      return CountingLaw::evaluate_f32(n, p, u);  // refuses, naming the precision
    }
  }
  bool supports(Precision precision) const override { return precision == Precision::kFloat64 || has_float32(); }

  // K from the constants, for a law that gives only those.
  template <class T>
  T eval(T n, T p, const T* u) const {
    return self().constants(n, p)(u);
  }

  std::unique_ptr<FixedEvaluator> fixed_evaluator(double n, double p, std::size_t rows) const override {
    const std::size_t k = static_cast<std::size_t>(this->n_uniforms());
    if constexpr (requires(const Derived& d) { d.table(n, p, rows); }) {
      if (rows >= kTabulateMinBatch) {
        if (auto t = self().table(n, p, rows)) {
          return make_fixed_evaluator(
              [this, n, p, k, rt = std::move(*t)](const double* u, std::size_t count, double* out) {
                rt.steps.sample_rows(u, k, rt.col, count, rt.f, out,
                                     [&](const double* row) { return self().eval(n, p, row); });
              });
        }
      }
    }
    if constexpr (requires(const Derived& d) { d.constants(n, p); }) {
      return make_fixed_evaluator([c = self().constants(n, p), k](const double* u, std::size_t count, double* out) {
        for (std::size_t r = 0; r < count; ++r) out[r] = c(u + r * k);
      });
    } else {
      return make_fixed_evaluator([this, n, p, k](const double* u, std::size_t count, double* out) {
        for (std::size_t r = 0; r < count; ++r) out[r] = self().eval(n, p, u + r * k);
      });
    }
  }

  void evaluate_pixels(const double* n, const double* p, const double* u, std::size_t count,
                       double* out) const override {
    const std::size_t k = static_cast<std::size_t>(this->n_uniforms());
    for (std::size_t i = 0; i < count; ++i) out[i] = self().eval(n[i], p[i], u + i * k);
  }

 private:
  const Derived& self() const { return static_cast<const Derived&>(*this); }
  // Whether eval takes floats: a template eval (or the constants), not a float64-only one. A function,
  // so that it is asked once Derived is complete.
  static constexpr bool has_float32() {
    return requires(const Derived& d, const float* uf) { d.eval(1.0f, 1.0f, uf); };
  }
};

}  // namespace glintlab::detail
