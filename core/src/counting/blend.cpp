#include "glintlab/counting/blend.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/detail/blend_stages.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"
#include "level_brackets.hpp"

namespace glintlab {

namespace {

constexpr std::size_t kChunk = 2048;

// A rule's trial counts come from products of areas and densities, which land a few ulps off the
// integers they stand for (N A_hi = n (A_hi / P) at P one ulp below A_hi; w N A_hi at w = 1e-16).
// Left alone, the stratified rule turns such an ulp into a Bernoulli facet, so K could reach
// ceil(n) + 1 (found by the extremes suite). Counts within 4 ulps of the pair's total from an
// integer are that integer; elsewhere the counts are untouched.
// std::round (half away from zero) without the libm call the baseline ISA makes of it (two per
// level and sample): x - trunc(x) is exact, so the comparison with 1/2 decides as round() does.
inline double round_half_away(double x) {
  if (!(std::abs(x) < 0x1p52)) return std::round(x);  // already an integer, or not finite
  const double t = static_cast<double>(static_cast<std::int64_t>(x));
  const double f = x - t;
  // As arithmetic on the comparisons, not a branch: the fractional parts of per-sample trial counts
  // (distributed) are random, so branches here mispredicted at every other sample. t + 1 - 0 and
  // t + 0 - 1 are exact for |t| < 2^52; t + 0 - 0 only turns a -0 into +0, which snaps to the same 0.
  return t + static_cast<double>(f >= 0.5) - static_cast<double>(f <= -0.5);
}

std::array<double, 2> snap_trials(std::array<double, 2> t) {
  const double tolerance = 4 * std::numeric_limits<double>::epsilon() * (std::abs(t[0]) + std::abs(t[1]));
  for (double& x : t) {
    const double r = round_half_away(x);
    x = std::abs(x - r) <= tolerance ? r : x;
  }
  return t;
}

// Records sample i as refused: the lowest index wins, whatever the threads' order.
void record_refused(std::atomic<std::size_t>& first, std::size_t i) {
  std::size_t seen = first.load();
  while (i < seen && !first.compare_exchange_weak(seen, i)) {}
}

}  // namespace

LevelLadder::LevelLadder(double ratio, double base_area) : ratio_(ratio), base_area_(base_area), log_ratio_(0.0) {
  if (!(ratio > 1.0) || !std::isfinite(ratio))
    throw_invalid("blended_law", "level_ratio", ratio, "a finite number > 1 (4 for mip levels)");
  if (!(base_area > 0.0) || !std::isfinite(base_area))
    throw_invalid("blended_law", "base_area", base_area, "a finite area > 0");
  log_ratio_ = std::log(ratio_);
  inv_log2_ratio_ = std::log(2.0) / log_ratio_;
  areas_.resize(2 * kTabulated + 1);
  for (int l = -kTabulated; l <= kTabulated; ++l)
    areas_[static_cast<std::size_t>(l + kTabulated)] = base_area_ * std::pow(ratio_, l);
  increasing_ = std::adjacent_find(areas_.begin(), areas_.end(), std::greater_equal<double>()) == areas_.end();
}

LevelBracket LevelLadder::bracket(double footprint_area) const {
  const double a = footprint_area;
  if (!(a > 0.0) || !std::isfinite(a)) throw_invalid("blended_law", "P", a, "a finite footprint area > 0");
  if (increasing_ && a >= areas_.front() && a < areas_.back()) {
    // Inside the table the level is its unique A_lo <= P < A_hi (the areas increase strictly), which
    // the logarithm's guess below settles on; a guess from P's binary exponent and mantissa
    // (log2 within 0.09) settled the same way finds it without a logarithm, in a step or two.
    const double x = a / base_area_;
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    const double rough_log2 = static_cast<double>(static_cast<std::int64_t>(bits >> 52) - 1023) +
                              static_cast<double>(bits & ((std::uint64_t{1} << 52) - 1)) * 0x1p-52;
    const double rough = std::floor(rough_log2 * inv_log2_ratio_);
    int lo = static_cast<int>(std::clamp(rough, static_cast<double>(-kTabulated), static_cast<double>(kTabulated - 1)));
    // The guess is at most one level off for ratios >= 1.5 (log2 within 0.09): one step each way
    // without a branch (random footprints made these steps mispredicted branches, the bulk of a
    // bracket's time), then the loops settle what is left (ratios nearer 1), rarely entered.
    lo -= static_cast<int>(lo > -kTabulated && areas_[static_cast<std::size_t>(lo + kTabulated)] > a);
    lo += static_cast<int>(lo + 1 < kTabulated && areas_[static_cast<std::size_t>(lo + 1 + kTabulated)] <= a);
    while (areas_[static_cast<std::size_t>(lo + kTabulated)] > a) --lo;
    while (areas_[static_cast<std::size_t>(lo + 1 + kTabulated)] <= a) ++lo;
    return bracket_at(a, lo);
  }
  const double guess = std::floor(std::log(a / base_area_) / log_ratio_);
  if (!(std::abs(guess) < 32767))
    throw_invalid("blended_law", "P", a, "an area within 32767 levels of base_area (level index is 16 bits)");
  int lo = static_cast<int>(guess);
  // The logarithm can land one level off near a level's area: settle A_lo <= P < A_hi exactly.
  while (area(lo) > a) --lo;
  while (area(lo + 1) <= a) ++lo;
  return bracket_at(a, lo);
}

namespace {
constexpr double kBelowOne = 0x1.fffffffffffffp-1;  // std::nextafter(1.0, 0.0), without the call
}

LevelBracket LevelLadder::bracket_at(double a, int lo) const {
  return bracket_at(a, lo, std::clamp(std::log(a / area(lo)) / log_ratio_, 0.0, kBelowOne));
}

LevelBracket LevelLadder::bracket_at(double a, int lo, double w_lod) const {
  LevelBracket b;
  b.lo = lo;
  b.area_lo = area(lo);
  b.area_hi = area(lo + 1);
  b.w_lod = w_lod;
  b.w_area = std::clamp((a - b.area_lo) / (b.area_hi - b.area_lo), 0.0, kBelowOne);
  return b;
}

void LevelLadder::brackets(const double* a, std::size_t m, LevelBracket* out) const { fill_brackets(a, m, out, true); }

void LevelLadder::brackets_without_lod(const double* a, std::size_t m, LevelBracket* out) const {
  fill_brackets(a, m, out, false);
}

void LevelLadder::fill_brackets(const double* a, std::size_t m, LevelBracket* out, bool with_lod) const {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!increasing_) {
    for (std::size_t r = 0; r < m; ++r) {
      out[r] = bracket(a[r]);
      if (!with_lod) out[r].w_lod = kNaN;
    }
    return;
  }
  // Blocks of rows through the vector passes (detail::level_passes: bracket()'s guess and its two
  // steps; detail::level_weights: bracket_at's weights), with the C library's logarithm between them.
  const detail::LadderTable table{areas_.data() + kTabulated, kTabulated, base_area_, inv_log2_ratio_};
  const double front = areas_.front(), back = areas_.back();
  constexpr std::size_t kBlock = 256;
  int lo[kBlock];
  double area_lo[kBlock], area_hi[kBlock], w_lod[kBlock], w_area[kBlock];
  for (std::size_t r0 = 0; r0 < m; r0 += kBlock) {
    const std::size_t rows = std::min(kBlock, m - r0);
    const double* x = a + r0;
    detail::level_passes(x, rows, table, lo, area_lo, area_hi, w_lod);
    if (with_lod)
      for (std::size_t r = 0; r < rows; ++r) w_lod[r] = std::log(w_lod[r]);
    detail::level_weights(x, rows, log_ratio_, area_lo, area_hi, w_lod, w_area);
    if (!with_lod) std::fill_n(w_lod, rows, kNaN);
    for (std::size_t r = 0; r < rows; ++r) {
      LevelBracket& b = out[r0 + r];
      b.lo = lo[r];
      b.area_lo = area_lo[r];
      b.area_hi = area_hi[r];
      b.w_lod = w_lod[r];
      b.w_area = w_area[r];
    }
    // Rows outside the table, or whose guess is still off (ratios near 1): bracket() itself.
    for (std::size_t r = 0; r < rows; ++r)
      if (!(x[r] >= front && x[r] < back && area_lo[r] <= x[r] && x[r] < area_hi[r])) [[unlikely]] {
        out[r0 + r] = bracket(x[r]);
        if (!with_lod) out[r0 + r].w_lod = kNaN;
      }
  }
}

void BlendRule::trials_rows(double density, const double* area, const LevelBracket* b, std::size_t m, double* t_lo,
                            double* t_hi) const {
  for (std::size_t r = 0; r < m; ++r) {
    const std::array<double, 2> t = trials(density, area[r], b[r]);
    t_lo[r] = t[0];
    t_hi[r] = t[1];
  }
}

InnerLaw InnerLaw::from_law(std::shared_ptr<const CountingLaw> law) {
  InnerLaw inner;
  inner.name = law->name();
  inner.n_uniforms = law->n_uniforms();
  inner.integer_output = law->binning() == "none";
  inner.thread_safe = true;
  const CountingLaw* raw = law.get();
  // The law's per-pixel path (vector code where the law has one; bit-identical to evaluate()).
  inner.evaluate = [raw](const double* n, const double* p, const double* u, std::size_t m, double* out) {
    detail::KernelOf(*raw)->evaluate_pixels(n, p, u, m, out);
  };
  inner.fixed_evaluator = [raw](double n, double p, std::size_t rows) {
    return detail::KernelOf(*raw)->fixed_evaluator(n, p, rows);
  };
  inner.law = std::move(law);
  return inner;
}

void BlendRule::combine_rows(double area, const LevelBracket& b, std::size_t m, const double* k_lo, const double* k_hi,
                             const FacetRows& facets, double* out) const {
  std::array<FacetStream, 2> streams;
  const bool reads_facets = thins();
  for (std::size_t r = 0; r < m; ++r) {
    if (reads_facets) streams = {facets.stream(r, 0), facets.stream(r, 1)};
    out[r] = combine(area, b, k_lo[r], k_hi[r], streams);
  }
}

void BlendRule::combine_rows_each(const double* area, const LevelBracket* b, std::size_t m, const double* k_lo,
                                  const double* k_hi, const FacetRows& facets, double* out) const {
  std::array<FacetStream, 2> streams;
  const bool reads_facets = thins();
  for (std::size_t r = 0; r < m; ++r) {
    if (reads_facets) streams = {facets.stream(r, 0), facets.stream(r, 1)};
    out[r] = combine(area[r], b[r], k_lo[r], k_hi[r], streams);
  }
}

Registry<BlendInfo>& blend_registry() {
  static Registry<BlendInfo> blends("blend");
  return blends;
}

bool register_blend(BlendInfo info) { return blend_registry().add(std::move(info)); }

std::vector<BlendInfo> registered_blends() { return blend_registry().all(); }

std::unique_ptr<BlendRule> make_blend(const std::string& name, const LawParams& params) {
  return blend_registry().make(name, params);
}

BlendedLaw::BlendedLaw(std::unique_ptr<BlendRule> rule, InnerLaw inner, LevelLadder ladder)
    : rule_(std::move(rule)), inner_(std::move(inner)), ladder_(ladder),
      evaluators_(std::make_shared<detail::blend_stages::LevelEvaluators>()) {
  if (!inner_.evaluate) throw std::logic_error("BlendedLaw: inner law without evaluate");
  if (inner_.n_uniforms < 0 || inner_.n_uniforms > 64)
    throw_invalid("blended_law", "inner.n_uniforms", inner_.n_uniforms, "0 to 64 uniforms");
}

std::string BlendedLaw::binning() const { return rule_->integer_output() && inner_.integer_output ? "none" : "round"; }

bool BlendedLaw::has_pmf() const {
  return rule_->has_pmf() && inner_.law && inner_.law->has_pmf() && inner_.integer_output;
}

double BlendedLaw::variance_ratio(double area) const { return rule_->variance_ratio(area, ladder_.bracket(area)); }

Distribution BlendedLaw::pmf(double density, double area, double p, std::size_t max_support) const {
  const std::string where = "blended_law('" + rule_->name() + "', inner='" + inner_.name + "')";
  check_n(where, density, "N");
  check_p(where, p);
  const LevelBracket b = ladder_.bracket(area);
  if (!has_pmf())
    throw not_implemented(where + " has no exact distribution: " +
                          (!rule_->has_pmf() ? std::string("the blend's K has a continuous part")
                           : inner_.law && inner_.law->has_pmf()
                               ? std::string("the inner law produces non-integer counts")
                               : std::string("the inner law has none")) +
                          "; estimate one from samples instead");
  const auto trials = snap_trials(rule_->trials(density, area, b));
  Distribution levels[2] = {Distribution({0.0}, {1.0}), Distribution({0.0}, {1.0})};
  for (int j = 0; j < 2; ++j) {
    if (!(trials[j] > 0)) continue;
    levels[j] = inner_.law->pmf(trials[j], p, max_support);
    for (double v : levels[j].support())
      if (v != std::floor(v))
        throw not_implemented(where + " has no exact distribution: the inner law gives the non-integer count " +
                              format_value(v) + " at n = " + format_value(trials[j]) + ", p = " + format_value(p) +
                              " (a blend's exact law needs integer level counts; sample it instead)");
  }
  return rule_->combine_pmf(area, b, levels[0], levels[1], max_support);
}

void BlendedLaw::check_sample(const std::string& where, double density, ParamArray area, ParamArray p,
                              std::size_t i) const {
  // Its P, its p, its level index, then the trial counts the rule asks of the inner law at its levels.
  const double a = area[i];
  if (!(a > 0.0) || !std::isfinite(a))
    throw_invalid(where, indexed_name("P", i, area.size > 1), a, "a finite footprint area > 0");
  check_p(where, p[i], indexed_name("p", i, p.size > 1));
  const LevelBracket b = ladder_.bracket(a);
  if (!inner_.law) return;
  for (double t : snap_trials(rule_->trials(density, a, b)))
    if (t > 0 && !inner_.law->accepts(t, p[i]))
      throw_invalid_message(where + ": the inner law refuses its trial count n = " + format_value(t) +
                            " at p = " + format_value(p[i]) + " (P = " + format_value(a) + ")");
}

void BlendedLaw::run(double density, ParamArray area, ParamArray p, std::size_t count,
                     const detail::blend_stages::RowStreams& streams, double* out) const {
  namespace stages = detail::blend_stages;
  const std::string where = "blended_law('" + rule_->name() + "', inner='" + inner_.name + "')";
  check_n(where, density, "N");
  check_length(where, "P", area.size, count);
  check_length(where, "p", p.size, count);
  stages::LevelEvaluators& evaluators = *evaluators_;
  // One footprint area and one p for the whole call (a flat patch, a study at one P): stages 1 and 2 once,
  // after the sample's own checks and before anything is drawn, and each drawn level's evaluator prepared
  // for the call's rows (a table where the law has one, kept for later calls at the same footprint).
  const bool one_footprint = area.size == 1 && p.size == 1;
  LevelBracket bracket{};
  double trials[2] = {0, 0};
  stages::LevelSpan span;
  if (one_footprint) {
    check_sample(where, density, area, p, 0);
    stages::bracket_rows(ladder_, true, true, area.data, p, 0, 1, &bracket);
    stages::trial_counts(*rule_, density, area.data, &bracket, 1, inner_.law.get(), &trials[0], &trials[1], span);
    for (const double t : trials)
      if (t > 0 && inner_.fixed_evaluator) evaluators.get(inner_, t, p[0], count);
  } else {
    // Arrays: the checks are fused into stages 1 and 2 (a chunk with a refused sample stops before drawing, a chunk
    // after the lowest refused sample found so far is not drawn, and that sample is checked again at the end to
    // throw its own message, as a serial scan would), so out may be partly written when the call throws. A scalar
    // P or p is checked once here.
    if (area.size == 1 && (!(area[0] > 0.0) || !std::isfinite(area[0])))
      throw_invalid(where, "P", area[0], "a finite footprint area > 0");
    if (p.size == 1) check_p(where, p[0]);
  }
  std::atomic<std::size_t> first_refused{count};
  auto chunk = [&](std::size_t i0, std::size_t i1) {
    if (first_refused.load(std::memory_order_relaxed) < i0) return;  // an earlier sample is refused
    stages::ScratchLease lease;
    stages::ChunkScratch& scratch = *lease;
    stages::ChunkRows rows;
    rows.i0 = i0;
    rows.m = i1 - i0;
    rows.p = p;
    if (one_footprint) {
      rows.areas = area.data;
      rows.brackets = &bracket;
      rows.trials[0] = &trials[0];
      rows.trials[1] = &trials[1];
      rows.step = 0;
      rows.span = span;
    } else if (const std::size_t refused = bracket_and_trial_rows(density, area, rows, scratch); refused < rows.m) {
      record_refused(first_refused, i0 + refused);
      return;
    }
    scratch.k_level[0].resize(rows.m);
    scratch.k_level[1].resize(rows.m);
    double* const k_lo = scratch.k_level[0].data();
    double* const k_hi = scratch.k_level[1].data();
    stages::level_counts(inner_, ladder_, streams, rows, evaluators, count, where, scratch, k_lo, k_hi);
    stages::combine_levels(*rule_, streams, rows, k_lo, k_hi, scratch, out + i0);
  };
  if (inner_.thread_safe) {
    detail::parallel_chunks(count, kChunk, kChunk, chunk);
  } else {
    for (std::size_t i0 = 0; i0 < count; i0 += kChunk) chunk(i0, std::min(count, i0 + kChunk));
  }
  if (const std::size_t i = first_refused.load(); i < count) {
    check_sample(where, density, area, p, i);
    throw std::logic_error(where + ": sample " + std::to_string(i) + " was refused but passes its checks");
  }
}

std::size_t BlendedLaw::bracket_and_trial_rows(double density, ParamArray area, detail::blend_stages::ChunkRows& rows,
                                               detail::blend_stages::ChunkScratch& scratch) const {
  namespace stages = detail::blend_stages;
  const std::size_t m = rows.m;
  if (area.size == 1) {
    scratch.areas.assign(m, area[0]);
    rows.areas = scratch.areas.data();
  } else {
    rows.areas = area.data + rows.i0;
  }
  scratch.brackets.resize(m);  // every row written by stage 1
  scratch.t_lo.resize(m);
  scratch.t_hi.resize(m);
  rows.brackets = scratch.brackets.data();
  rows.trials[0] = scratch.t_lo.data();
  rows.trials[1] = scratch.t_hi.data();
  const std::size_t refused = stages::bracket_rows(ladder_, rule_->reads_lod_weight(), area.size == 1, rows.areas,
                                                   rows.p, rows.i0, m, scratch.brackets.data());
  if (refused < m) return refused;
  return stages::trial_counts(*rule_, density, rows.areas, rows.brackets, m, inner_.law.get(), scratch.t_lo.data(),
                              scratch.t_hi.data(), rows.span);
}

void BlendedLaw::sample(double density, ParamArray area, ParamArray p, std::size_t count, std::uint64_t seed,
                        double* out) const {
  run(density, area, p, count, detail::blend_stages::RowStreams::index_cells(seed), out);
}

void BlendedLaw::sample_at(double density, ParamArray area, ParamArray p, ParamArray x, ParamArray y, std::size_t count,
                           std::uint64_t seed, double* out) const {
  const std::string where = "blended_law('" + rule_->name() + "').sample_at";
  for (auto [name, arr] : {std::pair<const char*, ParamArray>{"x", x}, {"y", y}}) {
    check_length(where, name, arr.size, count);
    for (std::size_t i = 0; i < arr.size; ++i)
      if (!std::isfinite(arr[i]) || std::abs(arr[i]) > 1e9)
        throw_invalid(where, indexed_name(name, i, arr.size > 1), arr[i], "a finite texture coordinate, |x| <= 1e9");
  }
  run(density, area, p, count, detail::blend_stages::RowStreams::positions(seed, x, y), out);
}

namespace blend_detail {

double thin(double k, double q, double u) {
  if (k <= 0 || q <= 0) return 0.0;
  if (q >= 1) return k;
  return binomial::quantile(u, std::floor(k), q);
}

Distribution thinned(const Distribution& counts, double q, std::size_t max_support) {
  const double hi = counts.support().back();
  if (hi + 1 > static_cast<double>(max_support))
    throw_invalid_message("roulette pmf: the law needs more than max_support = " + std::to_string(max_support) +
                          " support points");
  std::vector<double> probs(static_cast<std::size_t>(hi) + 1, 0.0);
  for (std::size_t i = 0; i < counts.size(); ++i) {
    const double k = counts.support()[i];
    if (counts.probs()[i] == 0) continue;
    if (q <= 0 || k == 0) {
      probs[0] += counts.probs()[i];
      continue;
    }
    const Distribution kept = binomial::distribution(k, std::min(q, 1.0), max_support);
    for (std::size_t s = 0; s < kept.size(); ++s)
      probs[static_cast<std::size_t>(kept.support()[s])] += counts.probs()[i] * kept.probs()[s];
  }
  std::vector<double> support, kept_probs;
  for (std::size_t v = 0; v < probs.size(); ++v) {
    if (probs[v] == 0) continue;
    support.push_back(static_cast<double>(v));
    kept_probs.push_back(probs[v]);
  }
  return Distribution::with_trimmed_tails(std::move(support), std::move(kept_probs), counts.trimmed_below() || q > 0,
                                          counts.trimmed_above() || q > 0);
}

}  // namespace blend_detail

}  // namespace glintlab
