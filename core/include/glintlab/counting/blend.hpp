// Blending a counting law between two LOD levels (docs/math/blends.md; DB23 §3-4, KPT25 §3.3.3, WB16 §3.2).
//
// Level l of the ladder has cells of area A_l = base_area · ratio^l (any integer l; ratio 4 for mip
// levels, whose texel side doubles, and 2 as DB23 eq. 13 prints). A footprint of area P sits
// between A_lo <= P < A_hi = ratio · A_lo. Each level draws its counts from its own cells: the count
// of level l at texture position (x, y) uses the random numbers keyed by (seed, cell of (x, y) at
// level l, l), so a realization is coherent across pixels and frames, and the two levels of one
// pixel are independent. A blend rule says how many trials the inner single-footprint law sees at
// each level and how the two level counts combine into K:
//
//   nearest      one level, round(w), K = (P / A_l) · b(N A_l, p)                (WB16 stepping)
//   zk16_linear  K = P [(1 - w) b(N A_lo, p) / A_lo + w b(N A_hi, p) / A_hi]     (ZK16 output blend)
//   distributed  K = b(w̲ N A_lo, p) + b(w̄ N A_hi, p), w̄ = (P - A_lo)/(A_hi - A_lo)  (DB23 eq. 10)
//   roulette     each reflecting facet of a level is kept with the level's weight (KPT25 eq. 8)
//
// with w = log_ratio(P / A_lo), the fractional LOD a mip chain uses, and b the inner law.
// Non-integer trial counts (w̄ N A_hi, ...) go to the inner law as they are; each law states its
// rule for them (the exact binomial: Binomial(floor n, p) + Bernoulli(frac(n) p)).
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "glintlab/base/registry.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/distribution.hpp"

namespace glintlab {

namespace detail {
class FixedEvaluator;     // detail/law_kernel.hpp
namespace blend_stages {  // detail/blend_stages.hpp
class RowStreams;
class LevelEvaluators;
struct ChunkRows;
struct ChunkScratch;
}  // namespace blend_stages
}  // namespace detail

// Where a footprint of area P sits on the level ladder.
struct LevelBracket {
  int lo;  // A_lo = base_area · ratio^lo <= P < A_hi
  double area_lo, area_hi;
  double w_lod;   // log_ratio(P / A_lo) in [0, 1): the fractional LOD
  double w_area;  // (P - A_lo) / (A_hi - A_lo) in [0, 1): DB23 eq. 10's weight of the upper level
};

class LevelLadder {
 public:
  // Validates (std::invalid_argument naming the parameter): ratio finite > 1, base_area finite > 0.
  LevelLadder(double ratio, double base_area);
  double ratio() const { return ratio_; }
  double base_area() const { return base_area_; }
  double area(int level) const {
    if (level >= -kTabulated && level <= kTabulated) return areas_[static_cast<std::size_t>(level + kTabulated)];
    return base_area_ * std::pow(ratio_, level);
  }
  // P finite > 0 whose level index fits 16 bits (|l| < 32768); otherwise std::invalid_argument.
  LevelBracket bracket(double footprint_area) const;
  // bracket(P) once its level lo is known (lo = bracket(P).lo; no checks): the same bits. With
  // w_lod = bracket(P).w_lod given too, without the logarithm.
  LevelBracket bracket_at(double footprint_area, int lo) const;
  LevelBracket bracket_at(double footprint_area, int lo, double w_lod) const;
  // out[r] = bracket(a[r]) for r < m, the same bits, for areas already checked finite and > 0, in
  // branch-free passes over the rows (level index, the areas' ratio, the logarithm, the weights):
  // random footprints made bracket()'s branches mispredict and serialize its logarithm, about 20 ns
  // a sample against 6 here. Throws as bracket() does (a level index beyond 16 bits).
  void brackets(const double* a, std::size_t m, LevelBracket* out) const;
  // The same without the fractional LOD (w_lod is NaN; no logarithm): for rules that do not read it
  // (BlendRule::reads_lod_weight).
  void brackets_without_lod(const double* a, std::size_t m, LevelBracket* out) const;

 private:
  // area(l) for |l| <= kTabulated, computed once by the same expression (a per-sample bracket then
  // costs two logarithms instead of three and four pow calls; the same bits).
  void fill_brackets(const double* a, std::size_t m, LevelBracket* out, bool with_lod) const;
  static constexpr int kTabulated = 256;
  double ratio_, base_area_, log_ratio_, inv_log2_ratio_ = 1;
  std::vector<double> areas_;
  bool increasing_ = false;  // areas_ strictly increasing: bracket() may bisect it
};

// The inner law as the blend sees it: a vectorized evaluation on explicit uniforms, so that a
// built-in law and a user's function (Python) are driven the same way.
struct InnerLaw {
  std::string name;
  int n_uniforms = 0;
  bool integer_output = true;  // counts are integers (exact pmfs need them)
  bool thread_safe = true;     // evaluate may run on several threads at once (not a Python callback)
  // out[i] = K for (n[i], p[i]) on uniforms u[i * n_uniforms ...]; called from one thread.
  std::function<void(const double* n, const double* p, const double* u, std::size_t m, double* out)> evaluate;
  std::shared_ptr<const CountingLaw> law;  // set for built-in laws: domain checks and exact pmfs
  // Optional (set for built-in laws): an evaluator of about `rows` rows at one (n, p), the same
  // results as evaluate (detail::LawKernel::fixed_evaluator: a table where the law has one). Used when every
  // row of a level shares (n, p): one footprint area, runs of equal P.
  std::function<std::unique_ptr<detail::FixedEvaluator>(double n, double p, std::size_t rows)> fixed_evaluator;

  static InnerLaw from_law(std::shared_ptr<const CountingLaw> law);
};

// A level cell's per-facet stream (roulette): CounterRng(seed, cell, level, kStreamLevelFacets), whose
// first Philox block may have been computed ahead by the vectorized rows (detail::
// philox_uniform_rows_level with k = 2, the same two numbers); the stream then continues from its
// second block. The same draws either way.
class FacetStream {
 public:
  FacetStream() : rng_(0, 0, 0) {}
  explicit FacetStream(const CounterRng& rng) : rng_(rng) {}
  FacetStream(const double* first_two, const CounterRng& rng) : first_{first_two[0], first_two[1]}, pos_(0), rng_(rng) {
    rng_.skip_blocks(1);  // the prefetched one
  }
  double uniform() {
    if (pos_ < 2) return first_[pos_++];
    return rng_.uniform();
  }

 private:
  double first_[2] = {0, 0};
  int pos_ = 2;
  CounterRng rng_;
};

// One blend rule (a file in core/blends/, registered by name).
class BlendRule {
 public:
  virtual ~BlendRule() = default;
  virtual std::string name() const = 0;
  virtual LawParams params() const { return {}; }
  // Trials handed to the inner law at the lower and upper level; 0 means the level is not drawn.
  virtual std::array<double, 2> trials(double density, double area, const LevelBracket& b) const = 0;
  // trials() of rows r < m into t_lo[r], t_hi[r] (the default calls trials() per row; the built-in
  // rules override it through RowwiseRule, the same bits without a virtual call per row).
  virtual void trials_rows(double density, const double* area, const LevelBracket* b, std::size_t m, double* t_lo,
                           double* t_hi) const;
  // Whether combine() reads the per-facet streams (roulette), and needs integer level counts.
  virtual bool thins() const { return false; }
  // Whether trials() and combine() read LevelBracket::w_lod (the fractional LOD, a logarithm per
  // footprint); a rule that answers false gets brackets whose w_lod is NaN when P varies per sample.
  virtual bool reads_lod_weight() const { return true; }
  // K from the level counts; `facets[j]` is level j's stream for per-facet decisions (thins() only).
  virtual double combine(double area, const LevelBracket& b, double k_lo, double k_hi,
                         std::array<FacetStream, 2>& facets) const = 0;
  // The facet streams of rows r < m of one call at one bracket, for combine_rows().
  struct FacetRows {
    // first[j] (or null): the first Philox block of row r's level-j stream, first[j][2 r] and
    // first[j][2 r + 1] (vectorized rows, sample()'s index cells).
    std::array<const double*, 2> first{nullptr, nullptr};
    // Row r's level-j stream from its start (serving first[j]'s block first when it is set).
    std::function<FacetStream(std::size_t r, int j)> stream;
  };
  // out[r] = combine(area, b, k_lo[r], k_hi[r], {facets.stream(r, 0), facets.stream(r, 1)}) for r < m,
  // at one footprint area (the default does exactly that); a rule may override it to hoist what
  // depends on the bracket alone, with the same bits.
  virtual void combine_rows(double area, const LevelBracket& b, std::size_t m, const double* k_lo, const double* k_hi,
                            const FacetRows& facets, double* out) const;
  // The same with a footprint area and bracket per row (P per sample): out[r] = combine(area[r], b[r],
  // k_lo[r], k_hi[r], {facets.stream(r, 0), facets.stream(r, 1)}) for r < m (the default does exactly
  // that). facets.first[j], when set, holds row r's level-j first block at [2 r], [2 r + 1] as above
  // (gathered from the levels' vectorized rows). A rule may override it to batch its per-row work
  // (vector code, moments per distinct weight), with the same bits.
  virtual void combine_rows_each(const double* area, const LevelBracket* b, std::size_t m, const double* k_lo,
                                 const double* k_hi, const FacetRows& facets, double* out) const;
  // Whether combine_pmf can give an exact law (given exact inner laws).
  virtual bool has_pmf() const { return true; }
  // Whether K is an integer when the inner counts are.
  virtual bool integer_output() const { return false; }
  // Exact law of K from the inner laws' exact laws at each level (a point mass at 0 where trials()
  // is 0), on
  // integer bins (round half up) when !integer_output(). Throws not_implemented when underivable.
  virtual Distribution combine_pmf(double area, const LevelBracket& b, const Distribution& lo, const Distribution& hi,
                                   std::size_t max_support) const = 0;
  // Var[K] / Var[Binomial(N P, p)] for an exact binomial inner law at footprint area P = `area`,
  // derived analytically by the rule (it does not depend on N or p); NaN when the rule has no
  // closed form. Declared with the rule so that studies comparing measured variance with the
  // analytic one need no per-rule branches of their own.
  virtual double variance_ratio(double /*area*/, const LevelBracket& /*b*/) const {
    return std::numeric_limits<double>::quiet_NaN();
  }
};

// c ? a : b by bit masks: a select the compiler cannot turn back into a branch (it did, for the
// ternaries of the per-sample loops, where a coin-flip condition such as nearest's round(w) made the
// branch mispredict at every other sample). Both operands are evaluated.
inline double select(bool c, double a, double b) {
  const std::uint64_t mask = std::uint64_t{0} - static_cast<std::uint64_t>(c);
  return std::bit_cast<double>((std::bit_cast<std::uint64_t>(a) & mask) | (std::bit_cast<std::uint64_t>(b) & ~mask));
}

// The row forms of a rule (trials_rows; combine_rows_each for a rule that reads no facet stream) by
// its own trials() and combine(), called on Rule (final) without virtual dispatch, so that the loops
// inline them. A rule that thins (roulette) overrides combine_rows_each itself.
template <class Rule>
class RowwiseRule : public BlendRule {
 public:
  void trials_rows(double density, const double* area, const LevelBracket* b, std::size_t m, double* t_lo,
                   double* t_hi) const override {
    const Rule& rule = static_cast<const Rule&>(*this);
    for (std::size_t r = 0; r < m; ++r) {
      const std::array<double, 2> t = rule.Rule::trials(density, area[r], b[r]);
      t_lo[r] = t[0];
      t_hi[r] = t[1];
    }
  }
  void combine_rows_each(const double* area, const LevelBracket* b, std::size_t m, const double* k_lo,
                         const double* k_hi, const FacetRows& facets, double* out) const override {
    if (thins()) return BlendRule::combine_rows_each(area, b, m, k_lo, k_hi, facets, out);
    const Rule& rule = static_cast<const Rule&>(*this);
    std::array<FacetStream, 2> unused;
    for (std::size_t r = 0; r < m; ++r) out[r] = rule.Rule::combine(area[r], b[r], k_lo[r], k_hi[r], unused);
  }
};

using BlendFactory = std::function<std::unique_ptr<BlendRule>(const LawParams&)>;
struct BlendInfo {
  std::string name;
  std::string summary;
  BlendFactory make;
};
// All blend rules (a function-local static: rules register from static initializers).
Registry<BlendInfo>& blend_registry();
bool register_blend(BlendInfo info);
std::vector<BlendInfo> registered_blends();
std::unique_ptr<BlendRule> make_blend(const std::string& name, const LawParams& params = {});

// Registration of a blend without parameters (any given parameter is refused by name).
template <class Rule>
bool register_parameterless_blend(const std::string& name, const std::string& summary) {
  return register_blend({name, summary, [name](const LawParams& params) -> std::unique_ptr<BlendRule> {
                           ParamReader(name, params).finish();
                           return std::make_unique<Rule>();
                         }});
}

// A blend rule, an inner law and a ladder: a counting law of (N, P, p) on LOD levels.
class BlendedLaw {
 public:
  BlendedLaw(std::unique_ptr<BlendRule> rule, InnerLaw inner, LevelLadder ladder);

  const BlendRule& rule() const { return *rule_; }
  const InnerLaw& inner() const { return inner_; }
  const LevelLadder& ladder() const { return ladder_; }
  // "none" when K is always an integer, else "round" (unit bins, as CountingLaw::binning).
  std::string binning() const;
  bool has_pmf() const;
  // The rule's analytic Var[K] / Var[Binomial(N P, p)] at footprint area P for a binomial inner law
  // (BlendRule::variance_ratio; NaN when the rule has none). Validates P like sample().
  double variance_ratio(double area) const;

  // Exact law of K (see BlendRule::combine_pmf); not_implemented when the inner law has no exact
  // law or produces non-integer counts.
  Distribution pmf(double density, double area, double p, std::size_t max_support = kDefaultMaxSupport) const;

  // Independent samples: sample i sits in cell (i mod 2^32, i >> 32) at every level. density is a
  // scalar; area and p are arrays of 1 or `count` values. Bad input throws std::invalid_argument
  // naming the lowest bad sample, on any thread count; with an array of P or p the checks are fused
  // into the draws, so out may then be partly written (as sample_many's with two arrays).
  void sample(double density, ParamArray area, ParamArray p, std::size_t count, std::uint64_t seed, double* out) const;
  // Counts at texture positions (x[i], y[i]): the cell of level l is (floor(x / s_l), floor(y / s_l))
  // with s_l = sqrt(A_l), so nearby pixels and successive frames share cells (coherence).
  void sample_at(double density, ParamArray area, ParamArray p, ParamArray x, ParamArray y, std::size_t count,
                 std::uint64_t seed, double* out) const;

 private:
  // sample() and sample_at(): the call cut into chunks, each through the four stages of
  // detail/blend_stages.hpp (brackets, trial counts, level rows, combine); `streams` holds the seed.
  void run(double density, ParamArray area, ParamArray p, std::size_t count,
           const detail::blend_stages::RowStreams& streams, double* out) const;
  // Stages 1 and 2 for a chunk of rows with a footprint area (or p) per sample: the first refused row, or
  // rows.m with rows' areas, brackets, trials and span set.
  std::size_t bracket_and_trial_rows(double density, ParamArray area, detail::blend_stages::ChunkRows& rows,
                                     detail::blend_stages::ChunkScratch& scratch) const;
  // Sample i's checks, throwing the message that names it (std::invalid_argument).
  void check_sample(const std::string& where, double density, ParamArray area, ParamArray p, std::size_t i) const;
  std::unique_ptr<BlendRule> rule_;
  InnerLaw inner_;
  LevelLadder ladder_;
  // The inner law's step tables of the levels drawn whole, kept across calls (detail::blend_stages::LevelEvaluators).
  std::shared_ptr<detail::blend_stages::LevelEvaluators> evaluators_;
};

// Parameters shared by the blend rules' implementations.
namespace blend_detail {
// Binomial thinning by inversion: how many of floor(k) facets are kept with probability q, from one
// uniform (monotone in q for a fixed uniform, so a zoom keeps facets switched on as q grows).
double thin(double k, double q, double u);
// The law of facets kept with probability q from a count with law `counts` (a binomial mixture).
Distribution thinned(const Distribution& counts, double q, std::size_t max_support);
// KPT25 eq. 8: how much of a facet with roulette number r is kept at level weight `weight`
// (eps = 0: the hard roulette [r < weight]).
double roulette_keep(double r, double weight, double eps);
// E[R(r, weight)] and E[R(r, weight)^2] for r ~ U(0, 1), in closed form (detail/roulette.hpp).
std::array<double, 2> roulette_moments(double weight, double eps);
}  // namespace blend_detail

}  // namespace glintlab
