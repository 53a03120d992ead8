// A counting law: a rule producing the count K of reflecting facets from (n, p) and a few uniform
// random numbers. Each law is one small unit in core/laws/<name>.cpp (evaluate, exact distribution
// when one exists, traits, a doc string) that registers itself by name; nothing else in the code
// base switches on law names. CountingLaw holds only what defines a law; its optional fast paths
// (batches, pixels, step tables, an exact law's own sampler) sit behind one kernel interface,
// detail::LawKernel (detail/law_kernel.hpp), each bit for bit what the definition gives.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "glintlab/base/registry.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/base/threads.hpp"  // set_num_threads, num_threads: the drivers below use them
#include "glintlab/stats/distribution.hpp"

namespace glintlab {

using ParamValue = std::variant<double, std::string>;

// Arithmetic a law is evaluated in. float32 rounds n, p and the uniforms to float and computes in
// float (a shader's view); results come back as double. Exact laws exist in float64 only.
enum class Precision { kFloat64, kFloat32 };
Precision precision_from_name(const std::string& name);  // "float64" / "float32"; throws naming it
std::string precision_name(Precision precision);
using LawParams = std::map<std::string, ParamValue>;

// The largest n a law is evaluated at. Counts are doubles: above 2^53 consecutive integers are no
// longer representable, so no integer-valued sampler can be exact there and loops that step a count
// by 1 stop advancing (the binomial's BTRD, the table inversions). Every built-in law declares this
// domain; a float32 law sees float(n), finite far beyond it.
struct NumericDomain {
  double max_n = 9007199254740992.0;  // 2^53
  std::string note = "counts above 2^53 (9.007e15) are not consecutive doubles";
};

namespace detail {
class LawKernel;  // a law's optional fast paths: detail/law_kernel.hpp
}

struct LawTraits;
class CountingLaw;
std::unique_ptr<CountingLaw> make_law(const std::string& name, const LawParams& params = {});

class CountingLaw {
 public:
  virtual ~CountingLaw() = default;

  virtual std::string name() const = 0;
  // Parameters as given to the factory, defaults filled in (for reports and reproducibility).
  virtual LawParams params() const { return {}; }
  // Random numbers one evaluate() consumes.
  virtual int n_uniforms() const = 0;

  // Deterministic evaluation: K from (n, p) and u[0 .. n_uniforms), each u in [0, 1].
  // Arguments are validated by the vectorized drivers below, not here (hot path).
  virtual double evaluate(double n, double p, const double* u) const = 0;
  // The same in float32 (see Precision); laws that support it say so in supports().
  virtual double evaluate_f32(double n, double p, const double* u) const;
  virtual bool supports(Precision precision) const { return precision == Precision::kFloat64; }
  // The law's fast paths (batches, pixels, tables), all bit for bit evaluate() or its own sampler:
  // nullptr when it has none (the drivers then use evaluate() on the fill_uniforms rows). See
  // detail/law_kernel.hpp; a law written as constants-then-a-row gets one from detail::KernelLaw.
  virtual const detail::LawKernel* kernel() const { return nullptr; }

  // How outputs are binned for pmf() and comparisons: "none" (compared as they are) or "round"
  // (round half up: unit bins [k - 1/2, k + 1/2)). Declared by the law's traits (LawTraits::binning,
  // from its output), set by make_law; "none" for a law built otherwise.
  const std::string& binning() const { return binning_; }

  virtual bool has_pmf() const { return false; }
  // Exact law of K; throws not_implemented when the law has none.
  virtual Distribution pmf(double n, double p, std::size_t max_support) const;

  // Whether (n, p) is in the law's domain: a finite n >= 0 up to the traits' numeric domain, and p
  // in [0, 1]. Cheap, and not virtual (a law declares its domain by LawTraits::domain): the drivers
  // call it for every element and build a message only on failure.
  bool accepts(double n, double p) const { return n >= 0.0 && n <= max_n_ && p >= 0.0 && p <= 1.0; }
  // The numeric domain of the law's traits (LawTraits::domain), set by make_law; a law built
  // otherwise accepts every finite n.
  double max_n() const { return max_n_; }
  // Throws std::invalid_argument naming the bad parameter ("n[12] = -1 ...") if !accepts(n, p).
  virtual void validate(double n, double p, std::size_t index, bool is_array) const;

  // The cost model: how much work one evaluate() at (n, p) does on top of its fixed cost, in the
  // law's own unit (zk16: Bernoulli trials of its explicit loop; threshold: expected steps of its
  // CDF walk). 0 for constant-time laws and for laws that do not model their cost (see
  // LawTraits::cost). Declared by the law, from the constants its sampler uses, so that a cost model
  // elsewhere (the scene advisor) cannot drift from the law. (n, p) must be accepted by accepts().
  virtual double work_units(double /*n*/, double /*p*/) const { return 0.0; }

 private:
  // make_law applies the registered traits (domain, binning): they are the law's declaration, not
  // something to change on a built law.
  friend std::unique_ptr<CountingLaw> make_law(const std::string& name, const LawParams& params);
  void apply_traits(const LawTraits& traits);

  double max_n_ = 1.7976931348623157e308;
  std::string domain_note_{};
  std::string binning_ = "none";
};

// What a law declares about itself, next to its code (core/laws/<name>.cpp), so that studies,
// benchmarks, bounds and checks derive their lists from the registry instead of keeping name lists
// of their own. A law that declares nothing (a plugin) gets these defaults, which promise nothing:
// real output, no support bound, not constant time, in no study.
enum class LawOutput {
  kInteger,  // evaluate() returns integer counts in every precision (binning() is "none")
  kReal,     // real values (a gate ramp, a mean, a clamped Gaussian): binning() is "round" unless
             // LawTraits::bin_real says the values are compared as they are
};
std::string law_output_name(LawOutput output);  // "integer", "real"

enum class SupportBound {
  kBoundedByN,  // 0 <= K <= ceil(n), the stratified binomial's range
  kNPlusOne,    // 0 <= K <= ceil(n) + 1 (a defect reproduced on purpose, e.g. the public shader's)
  kUnbounded,   // K >= 0 only (another facet model: the Poisson layout)
};
std::string support_bound_name(SupportBound bound);  // "bounded_by_n", "n_plus_one", "unbounded"

// A region of the (n, p) plane where an error bound on the law is meant to hold, with the metrics
// bounded there and why (the law's intended regime, not where it happens to be good).
struct BoundDomain {
  LawParams params{};  // the variant the bound is for ({}: the defaults)
  // Ranges in declaration order (the order names the bound): "p_range", "n_range", "np_range" -> [lo,
  // hi]. Empty: the whole standard grid.
  std::vector<std::pair<std::string, std::array<double, 2>>> regime{};
  std::vector<std::string> metrics{};  // metric names (metrics.hpp): "tv", "mean_rel_err", ...
  std::string reason{};
};

struct LawTraits {
  LawOutput output = LawOutput::kReal;
  SupportBound support = SupportBound::kUnbounded;
  std::string support_note{};  // why, when the bound is not ceil(n)
  // Cost independent of (n, p): work_units() is 0 everywhere.
  bool constant_time = false;
  // An exact model (binomial, Poisson) that approximations are measured against, not an
  // approximation of the binomial itself.
  bool reference = false;
  std::string regime{};  // one line: where the law is meant to be used (empty: nothing declared)
  std::string cost{};    // one line: what the cost grows with, and what work_units() counts
  // Parameter sets (each {} = defaults) used by: the speed/accuracy trade study, the ns/sample
  // benchmark, and the generic law tests (which also exercise non-default parameters).
  std::vector<LawParams> study_variants{};
  std::vector<LawParams> bench_variants{};
  std::vector<LawParams> test_variants{};
  // (n, p) points that separate the law's cost terms (fixed cost vs. work units) when timing it;
  // empty for constant-time laws (any point will do).
  std::vector<std::array<double, 2>> cost_points{};
  std::vector<BoundDomain> bounds{};
  // The stem of the shader glintlab ships for this law (data/shaders/<shader>.hlsl and .glsl, its
  // float32 twin compared row by row); empty when there is none.
  std::string shader{};
  // Where the law is evaluated at all: n beyond max_n is refused with std::invalid_argument.
  NumericDomain domain{};
  // Real outputs (kReal) are compared in unit bins (round half up) unless they are exact as they
  // are: threshold's mean n p is a point mass of its exact law, not a count to round.
  bool bin_real = true;

  // CountingLaw::binning(): "round" for real outputs that are binned, else "none".
  std::string binning() const { return output == LawOutput::kReal && bin_real ? "round" : "none"; }
  bool declared() const { return !regime.empty(); }
  // Largest count the law can return at n (+inf when unbounded). A law evaluated in float32 sees
  // float(n): callers pass the n the law computes with.
  double max_count(double n) const;
};

// Batches at least this long amortize a per-(n, p) table (e.g. inversion tables); results must not
// depend on the choice.
inline constexpr std::size_t kTabulateMinBatch = 64;

using LawFactory = std::function<std::unique_ptr<CountingLaw>(const LawParams&)>;

struct LawInfo {
  std::string name;
  std::string summary;  // one line for listings
  LawFactory make;
  LawTraits traits{};  // declared in the law's own file (defaults: nothing promised)
};

// All laws, built-in and plugin. A function-local static, so that laws registering from static
// initializers in other files find it constructed.
Registry<LawInfo>& law_registry();

// Registration from a static initializer in the law's own file:
//   static const bool registered = glintlab::register_law({"binomial", "...", factory, traits});
// These wrappers keep the interface that laws, plugins and the bindings already use.
bool register_law(LawInfo info);
std::unique_ptr<CountingLaw> make_law(const std::string& name, const LawParams& params);
std::vector<LawInfo> registered_laws();
// The traits of a registered law (std::invalid_argument for an unknown name).
LawTraits law_traits(const std::string& name);

// Reads law parameters with defaults and rejects unknown or mistyped ones, naming them.
class ParamReader {
 public:
  ParamReader(std::string law, LawParams params) : law_(std::move(law)), params_(std::move(params)) {}
  double number(const std::string& key, double fallback);
  std::string text(const std::string& key, const std::string& fallback, const std::vector<std::string>& allowed);
  // Throws if a parameter was given that no number()/text() call asked for.
  void finish() const;

 private:
  std::string law_;
  LawParams params_;
  std::vector<std::string> known_;
};

// Registration of a law without parameters (any given parameter is refused by name).
template <class Law>
bool register_parameterless_law(const std::string& name, const std::string& summary, LawTraits traits = {}) {
  return register_law({name, summary,
                       [name](const LawParams& params) -> std::unique_ptr<CountingLaw> {
                         ParamReader(name, params).finish();
                         return std::make_unique<Law>();
                       },
                       std::move(traits)});
}

// Parameter arrays for the vectorized drivers: `size` is 1 (broadcast) or the batch count.
struct ParamArray {
  const double* data;
  std::size_t size;
  double operator[](std::size_t i) const { return data[size == 1 ? 0 : i]; }
};

// out[i] = K for (n[i], p[i]) drawn with the counter RNG. Bad input throws, naming the lowest bad
// index; with n and p both arrays the check is fused into the draws, so out may then be partly written.
// In float32, sample i is evaluate_f32 on the uniforms of row i (those of fill_uniforms).
void sample_many(const CountingLaw& law, ParamArray n, ParamArray p, std::size_t count, std::uint64_t seed, double* out,
                 Precision precision = Precision::kFloat64);
// out[i] = law.evaluate(n[i], p[i], u + i * n_uniforms); validates everything first.
void evaluate_many(const CountingLaw& law, ParamArray n, ParamArray p, const double* u, std::size_t count, double* out,
                   Precision precision = Precision::kFloat64);
// Row-major count x k uniforms in (0, 1): row r holds the first k draws of
// CounterRng::for_index(seed, start + r, stream). With stream = kStreamSample these are exactly the
// numbers the drivers hand to evaluate() (detail::LawKernel's default sample_range), so a law re-implemented in Python
// as a custom law reproduces the built-in's samples seed for seed.
void fill_uniforms(std::uint64_t seed, std::uint16_t stream, std::size_t start, std::size_t count, int k, double* out);

}  // namespace glintlab
