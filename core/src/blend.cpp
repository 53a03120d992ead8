#include "glintlab/blend.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>

#include "glintlab/binomial.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/errors.hpp"
#include "level_brackets.hpp"
#include "parallel.hpp"

namespace glintlab {

namespace {

// Level l's 16-bit key in the counter (two's complement, so negative levels are distinct).
std::uint16_t level_key(int level) { return static_cast<std::uint16_t>(static_cast<std::int16_t>(level)); }

constexpr std::size_t kChunk = 2048;

// An allocator whose value-less construct() leaves scalars uninitialized: the per-chunk buffers below
// are written before they are read, and the zero fill of std::vector's resize() showed in profiles
// (about 10 % of the instructions of a blend with P per sample).
template <class T>
struct UninitializedAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = UninitializedAllocator<U>;
  };
  UninitializedAllocator() = default;
  template <class U>
  UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
  template <class U, class... Args>
  void construct(U* at, Args&&... args) {
    if constexpr (sizeof...(Args) == 0)
      ::new (static_cast<void*>(at)) U;
    else
      ::new (static_cast<void*>(at)) U(std::forward<Args>(args)...);
  }
};
template <class T>
using Scratch = std::vector<T, UninitializedAllocator<T>>;

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

// Fixed evaluators of the (n, p) pairs that whole chunks share (runs of equal P and p in arrays),
// kept for the chunks that follow, since a run usually spans several. Shared by the threads of one
// call; a few entries, the oldest replaced.
class FixedEvaluatorCache {
 public:
  std::shared_ptr<const detail::FixedEvaluator> get(const InnerLaw& inner, double n, double p, std::size_t rows) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& e : entries_)
        if (e.n == n && e.p == p) return e.evaluator;
    }
    std::shared_ptr<const detail::FixedEvaluator> made = inner.fixed_evaluator(n, p, rows);
    const std::lock_guard<std::mutex> lock(mutex_);
    if (entries_.size() < kEntries)
      entries_.push_back({n, p, made});
    else
      entries_[next_++ % kEntries] = {n, p, made};
    return made;
  }

 private:
  static constexpr std::size_t kEntries = 8;
  struct Entry {
    double n, p;
    std::shared_ptr<const detail::FixedEvaluator> evaluator;
  };
  std::mutex mutex_;
  std::vector<Entry> entries_;
  std::size_t next_ = 0;
};

// The per-chunk buffers of a blend call, kept per thread across chunks and calls: buffers allocated
// per chunk cost page faults (glibc returns freed memory above its trim threshold to the kernel, and
// takes it back zeroed), a quarter of a P-per-sample call's time. Every buffer is written before it
// is read. A nested call on the same thread (a Python inner law that samples a blend) leases another.
struct ChunkScratch {
  Scratch<LevelBracket> brackets;
  Scratch<std::size_t> rows[2], order;
  Scratch<double> n[2], pp[2], u[2], kk[2], k_level[2], t_lo, t_hi, areas, block, counts, blocks, group_u, group_k,
      first_blocks, gathered;
  Scratch<std::uint8_t> group_of;
};

class ScratchLease {
 public:
  ScratchLease() {
    auto& pool = free_list();
    if (pool.empty()) {
      held_ = std::make_unique<ChunkScratch>();
    } else {
      held_ = std::move(pool.back());
      pool.pop_back();
    }
  }
  ~ScratchLease() { free_list().push_back(std::move(held_)); }
  ScratchLease(const ScratchLease&) = delete;
  ScratchLease& operator=(const ScratchLease&) = delete;
  ChunkScratch& operator*() { return *held_; }

 private:
  static std::vector<std::unique_ptr<ChunkScratch>>& free_list() {
    thread_local std::vector<std::unique_ptr<ChunkScratch>> pool;
    return pool;
  }
  std::unique_ptr<ChunkScratch> held_;
};

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
    : rule_(std::move(rule)), inner_(std::move(inner)), ladder_(ladder) {
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

template <class CellOf>
void BlendedLaw::run(double density, ParamArray area, ParamArray p, std::size_t count, std::uint64_t seed,
                     CellOf cell_of, double* out) const {
  const std::string where = "blended_law('" + rule_->name() + "', inner='" + inner_.name + "')";
  check_n(where, density, "N");
  check_length(where, "P", area.size, count);
  check_length(where, "p", p.size, count);
  // One sample's checks, throwing the message that names it: its P, its p, its level index, then the
  // trial counts the rule asks of the inner law at its levels.
  auto check_sample = [&](std::size_t i) {
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
  };
  const std::size_t k = static_cast<std::size_t>(inner_.n_uniforms);
  const bool thins = rule_->thins();
  // Sample i's cells are (i mod 2^32, i >> 32) at every level (sample(), not sample_at()): the
  // level's uniforms are then rows of the vectorized Philox keyed at that level (the same numbers as
  // one CounterRng per cell).
  constexpr bool kIndexCells = requires { CellOf::kIndexCells; };
  // n and p: one value per row (step 1) or one for all (step 0).
  auto check_finite = [&](const double* kk, std::size_t rows, const double* n, const double* pp, std::size_t step) {
    for (std::size_t q = 0; q < rows; ++q)
      if (!std::isfinite(kk[q]))
        throw_invalid_message(where + ": the inner law returned " + format_value(kk[q]) +
                              " at n = " + format_value(n[q * step]) + ", p = " + format_value(pp[q * step]));
  };
  // The level counts into K; the facet streams only for rules that thin (roulette).
  // drawn: for one footprint area (bracket_step 0), which levels have trials (an undrawn level's
  // facets are never read).
  auto combine_rows = [&](ChunkScratch& scratch, std::size_t i0, std::size_t m, const LevelBracket* brackets,
                          std::size_t bracket_step, const double* k_lo, const double* k_hi,
                          std::array<bool, 2> drawn = {true, true}) {
    // sample()'s facet streams (index cells): the first Philox block of each row's stream at each
    // level, computed ahead as vectorized rows (one block per level the chunk spans; a scalar Philox
    // block per row and level was most of the roulette's cost). The same numbers.
    int level_min = 0, span = 0;
    double* first_blocks = nullptr;
    constexpr int kMaxFacetLevels = 7;
    if constexpr (kIndexCells) {
      if (thins && m > 0) {
        int lmin = std::numeric_limits<int>::max(), lmax = std::numeric_limits<int>::min();
        for (std::size_t r = 0; r < m; ++r) {
          const int lo = brackets[r * bracket_step].lo;
          lmin = std::min(lmin, lo);
          lmax = std::max(lmax, lo + 1);
          if (bracket_step == 0) break;
        }
        if (lmax - lmin < kMaxFacetLevels) {
          level_min = lmin;
          span = lmax - lmin + 1;
          scratch.first_blocks.resize(static_cast<std::size_t>(span) * m * 2);
          first_blocks = scratch.first_blocks.data();
          for (int l = 0; l < span; ++l) {
            if (bracket_step == 0 && !drawn[static_cast<std::size_t>(level_min + l - brackets[0].lo)]) continue;
            detail::philox_uniform_rows_level(seed, level_key(level_min + l), kStreamLevelFacets, i0, m, 2,
                                              first_blocks + static_cast<std::size_t>(l) * m * 2);
          }
        }
      }
    }
    if (bracket_step == 0) {
      // One bracket for every row: the rule's batch form (the same bits as combine() per row).
      const LevelBracket& b = brackets[0];
      BlendRule::FacetRows rows;
      if (first_blocks)
        for (int j = 0; j < 2; ++j)
          if (drawn[static_cast<std::size_t>(j)])
            rows.first[static_cast<std::size_t>(j)] =
                first_blocks + static_cast<std::size_t>(b.lo + j - level_min) * m * 2;
      rows.stream = [&](std::size_t r, int j) {
        const auto [cx, cy] = cell_of(i0 + r, j == 0 ? b.area_lo : b.area_hi);
        const CounterRng rng(seed, cx, cy, level_key(b.lo + j), kStreamLevelFacets);
        const double* first = rows.first[static_cast<std::size_t>(j)];
        return first ? FacetStream(first + 2 * r, rng) : FacetStream(rng);
      };
      rule_->combine_rows(area[0], b, m, k_lo, k_hi, rows, out + i0);
      return;
    }
    // A bracket per row: each row's first blocks gathered into the layout of the one-bracket form, so
    // that a rule's combine_rows_each reads them as combine_rows does.
    BlendRule::FacetRows rows;
    if (first_blocks) {
      scratch.gathered.resize(4 * m);
      for (int j = 0; j < 2; ++j) {
        double* dst = scratch.gathered.data() + static_cast<std::size_t>(j) * 2 * m;
        for (std::size_t r = 0; r < m; ++r) {
          const auto l = static_cast<std::size_t>(brackets[r].lo + j - level_min);
          dst[2 * r] = first_blocks[(l * m + r) * 2];
          dst[2 * r + 1] = first_blocks[(l * m + r) * 2 + 1];
        }
        rows.first[static_cast<std::size_t>(j)] = dst;
      }
    }
    rows.stream = [&](std::size_t r, int j) {
      const LevelBracket& b = brackets[r];
      const auto [cx, cy] = cell_of(i0 + r, j == 0 ? b.area_lo : b.area_hi);
      const CounterRng rng(seed, cx, cy, level_key(b.lo + j), kStreamLevelFacets);
      const double* first = rows.first[static_cast<std::size_t>(j)];
      return first ? FacetStream(first + 2 * r, rng) : FacetStream(rng);
    };
    const double* areas = area.data + i0;
    if (area.size == 1) {
      scratch.areas.assign(m, area[0]);
      areas = scratch.areas.data();
    }
    rule_->combine_rows_each(areas, brackets, m, k_lo, k_hi, rows, out + i0);
  };

  // One footprint area and one p for the whole batch (a flat patch, a study at one P): one bracket,
  // one pair of trial counts, and each drawn level at one (n, p), evaluated by the inner law's fixed
  // evaluator (a table built once for the batch where the law has one) instead of per pixel.
  if (area.size == 1 && p.size == 1) {
    check_sample(0);  // before anything is drawn
    const LevelBracket b = ladder_.bracket(area[0]);
    const auto trials = snap_trials(rule_->trials(density, area[0], b));
    std::unique_ptr<detail::FixedEvaluator> evaluators[2];
    for (int j = 0; j < 2; ++j)
      if (trials[j] > 0 && inner_.fixed_evaluator) evaluators[j] = inner_.fixed_evaluator(trials[j], p[0], count);
    auto chunk_body = [&](std::size_t i0, std::size_t i1) {
      const std::size_t m = i1 - i0;
      // Uninitialized where every element is written (a zero fill per row and buffer showed in the
      // profile); an undrawn level's counts are zeros.
      ScratchLease lease;
      ChunkScratch& scratch = *lease;
      Scratch<double>& u = scratch.block;
      u.resize(std::max<std::size_t>(m * k, 1));
      Scratch<double>* k_level = scratch.k_level;
      Scratch<double>&n_rows = scratch.n[0], &p_rows = scratch.pp[0];
      for (int j = 0; j < 2; ++j) {
        k_level[j].resize(m);
        if (!(trials[j] > 0)) {
          std::fill_n(k_level[j].data(), m, 0.0);
          continue;
        }
        const int level = b.lo + j;
        if constexpr (kIndexCells) {
          if (k > 0)
            detail::philox_uniform_rows_level(seed, level_key(level), kStreamLevelCount, i0, m, static_cast<int>(k),
                                              u.data());
        } else {
          for (std::size_t r = 0; r < m; ++r) {
            const auto [cx, cy] = cell_of(i0 + r, j == 0 ? b.area_lo : b.area_hi);
            CounterRng rng(seed, cx, cy, level_key(level), kStreamLevelCount);
            for (std::size_t d = 0; d < k; ++d) u[r * k + d] = rng.uniform();
          }
        }
        if (evaluators[j]) {
          evaluators[j]->evaluate(u.data(), m, k_level[j].data());
          check_finite(k_level[j].data(), m, &trials[j], p.data, 0);
        } else {
          n_rows.assign(m, trials[j]);
          p_rows.assign(m, p[0]);
          inner_.evaluate(n_rows.data(), p_rows.data(), u.data(), m, k_level[j].data());
          check_finite(k_level[j].data(), m, n_rows.data(), p_rows.data(), 1);
        }
      }
      combine_rows(scratch, i0, m, &b, 0, k_level[0].data(), k_level[1].data(), {trials[0] > 0, trials[1] > 0});
    };
    if (inner_.thread_safe) {
      detail::parallel_chunks(count, kChunk, kChunk, chunk_body);
    } else {
      for (std::size_t i0 = 0; i0 < count; i0 += kChunk) chunk_body(i0, std::min(count, i0 + kChunk));
    }
    return;
  }

  // Arrays: per-sample brackets. A level whose rows in a chunk all share one (n, p) (runs of equal P
  // and p) gets a fixed evaluator, kept for the following chunks of the run.
  // The checks are fused into the draws (one bracket and one pair of trial counts per sample, not
  // two): a chunk with a refused sample stops before drawing, a chunk after the lowest refused sample
  // found so far is not drawn, and the lowest refused sample is then checked again to throw its own
  // message, as a serial scan would. So out may be partly written when the call throws.
  // Scalar P or p are checked once here.
  if (area.size == 1 && (!(area[0] > 0.0) || !std::isfinite(area[0])))
    throw_invalid(where, "P", area[0], "a finite footprint area > 0");
  if (p.size == 1) check_p(where, p[0]);
  std::atomic<std::size_t> first_refused{count};
  FixedEvaluatorCache cache;
  auto chunk_body = [&](std::size_t i0, std::size_t i1) {
    if (first_refused.load(std::memory_order_relaxed) < i0) return;  // an earlier sample is refused
    const std::size_t m = i1 - i0;
    ScratchLease lease;
    ChunkScratch& scratch = *lease;
    scratch.brackets.resize(m);  // every row written below
    LevelBracket* const brackets = scratch.brackets.data();
    // Per level slot: the rows it is drawn for (compacted), their trials, p, uniforms and counts.
    auto& rows = scratch.rows;
    auto& n = scratch.n;
    auto& pp = scratch.pp;
    auto& u = scratch.u;
    auto& kk = scratch.kk;
    auto& k_level = scratch.k_level;
    std::size_t drawn_at[2] = {0, 0};
    for (int j = 0; j < 2; ++j) {
      rows[j].resize(m);
      n[j].resize(m);
      pp[j].resize(m);
      k_level[j].assign(m, 0.0);
    }
    int level_min = std::numeric_limits<int>::max(), level_max = std::numeric_limits<int>::min();
    // The checks, brackets and trial counts in passes over the chunk's rows (a per-row sequence of
    // them mispredicted on random footprints); the first refused row stops the chunk.
    std::size_t refused_at = m;
    auto refused = [&](std::size_t r) {
      const double a = area[i0 + r], pi = p[i0 + r];
      return !(a > 0.0) | !(a <= std::numeric_limits<double>::max()) | !(pi >= 0.0) | !(pi <= 1.0);
    };
    bool any_refused = false;
    for (std::size_t r = 0; r < m; ++r) any_refused |= refused(r);
    if (any_refused) [[unlikely]]
      for (refused_at = 0; !refused(refused_at);) ++refused_at;
    const double* areas = area.data + (area.size == 1 ? 0 : i0);
    if (area.size == 1) {
      scratch.areas.assign(m, area[0]);
      areas = scratch.areas.data();
    }
    if (refused_at == m) {
      try {
        if (area.size == 1)
          std::fill_n(brackets, m, ladder_.bracket(area[0]));
        else if (rule_->reads_lod_weight())
          ladder_.brackets(areas, m, brackets);
        else
          ladder_.brackets_without_lod(areas, m, brackets);
      } catch (const std::invalid_argument&) {
        // A level index beyond 16 bits: which row (bracket() throws on the same rows).
        for (refused_at = 0; refused_at < m; ++refused_at) {
          try {
            ladder_.bracket(areas[refused_at]);
          } catch (const std::invalid_argument&) { break; }
        }
      }
    }
    Scratch<double>&t_lo = scratch.t_lo, &t_hi = scratch.t_hi;
    t_lo.resize(m);
    t_hi.resize(m);
    if (refused_at == m) rule_->trials_rows(density, areas, brackets, m, t_lo.data(), t_hi.data());
    const CountingLaw* law = inner_.law.get();
    const double max_n = law ? law->max_n() : std::numeric_limits<double>::infinity();
    // The trial counts snapped in place, the inner law's domain, and the span of levels drawn.
    if (refused_at == m) detail::snap_trial_rows(t_lo.data(), t_hi.data(), m);
    for (std::size_t r = 0; r < m && refused_at == m; ++r) {
      const std::array<double, 2> trials = {t_lo[r], t_hi[r]};
      // CountingLaw::accepts (p was checked above), with & so that it compiles to selects.
      const bool drawn[2] = {trials[0] > 0, trials[1] > 0};
      if (law && ((drawn[0] & !(trials[0] <= max_n)) | (drawn[1] & !(trials[1] <= max_n)))) [[unlikely]] {
        refused_at = r;
        break;
      }
      // The lowest level a row draws is lo unless it draws only the upper one; the highest is lo + 1
      // if it draws the upper one (a row drawing neither widens the span harmlessly: no level is
      // evaluated that no row draws). Arithmetic, not a branch per row.
      const int lo = brackets[r].lo;
      level_min = std::min(level_min, lo + static_cast<int>(!drawn[0]));
      level_max = std::max(level_max, lo + static_cast<int>(drawn[1]));
    }
    if (refused_at < m) {
      record_refused(first_refused, i0 + refused_at);
      return;
    }
    const double* trials_of[2] = {t_lo.data(), t_hi.data()};
    constexpr int kMaxVectorLevels = 6;
    // Level by level, without sorting rows (sample(), a built-in law, and every row that draws a
    // level doing so at one (n, p): the rules that draw N A_l trials, with one p or runs of equal p).
    // Level l's uniforms for rows i0.. are one block of vectorized Philox rows, so the fixed
    // evaluator of level l runs over the whole block in place and each row picks its two levels'
    // counts. Rows that do not draw level l are evaluated too (about half of them with footprints
    // spread over two levels) and dropped: cheaper than gathering uniforms and scattering counts per
    // group. Each kept count is evaluate() on the row's own uniforms: the same bits.
    if constexpr (kIndexCells) {
      const bool narrow = level_min <= level_max && level_max - level_min < kMaxVectorLevels;
      if (k > 0 && narrow && inner_.fixed_evaluator && m >= kTabulateMinBatch) {
        const auto span = static_cast<std::size_t>(level_max - level_min + 1);
        std::array<double, kMaxVectorLevels> level_n, level_p;
        level_n.fill(std::numeric_limits<double>::quiet_NaN());
        level_p.fill(std::numeric_limits<double>::quiet_NaN());
        // Each level's (n, p) from the first row that draws it (a few rows), then every row checked
        // against them, reading only: no store in the loop, no branch per row (nearest's levels are a
        // coin flip per row), in blocks of 64 rows, leaving at the first block with a second (n, p)
        // (distributed).
        std::size_t found = 0;
        for (std::size_t r = 0; r < m && found < span; ++r) {
          for (int j = 0; j < 2; ++j) {
            const double t = trials_of[j][r];
            const int l = brackets[r].lo + j - level_min;
            if (t > 0 && level_n[static_cast<std::size_t>(l)] != level_n[static_cast<std::size_t>(l)]) {
              level_n[static_cast<std::size_t>(l)] = t;
              level_p[static_cast<std::size_t>(l)] = p[i0 + r];
              ++found;
            }
          }
        }
        bool one_pair = true;
        for (std::size_t r0 = 0; r0 < m && one_pair; r0 += 64) {
          const std::size_t r1 = std::min(m, r0 + 64);
          for (int j = 0; j < 2; ++j) {
            for (std::size_t r = r0; r < r1; ++r) {
              const double t = trials_of[j][r], pi = p[i0 + r];
              const auto l =
                  static_cast<std::size_t>(std::clamp(brackets[r].lo + j - level_min, 0, level_max - level_min));
              one_pair &= (!(t > 0)) | ((level_n[l] == t) & (level_p[l] == pi));
            }
          }
        }
        if (one_pair) {
          const std::size_t stride = m * k;
          scratch.block.resize(stride);
          scratch.counts.resize(span * m);
          double* const block = scratch.block.data();
          double* const counts = scratch.counts.data();
          for (std::size_t l = 0; l < span; ++l) {
            if (level_n[l] != level_n[l]) continue;  // no row draws this level
            detail::philox_uniform_rows_level(seed, level_key(level_min + static_cast<int>(l)), kStreamLevelCount, i0,
                                              m, static_cast<int>(k), block);
            cache.get(inner_, level_n[l], level_p[l], count)->evaluate(block, m, counts + l * m);
          }
          for (int j = 0; j < 2; ++j) {
            const double* t = trials_of[j];
            double* kj = k_level[j].data();
            for (std::size_t r = 0; r < m; ++r) {
              // A row that does not draw level j reads a count of the span too (in range, dropped).
              const auto l =
                  static_cast<std::size_t>(std::clamp(brackets[r].lo + j - level_min, 0, level_max - level_min));
              kj[r] = select(t[r] > 0, counts[l * m + r], 0.0);
            }
            for (std::size_t r = 0; r < m; ++r)
              if (!std::isfinite(kj[r])) [[unlikely]]
                check_finite(kj + r, 1, t + r, p.data + (p.size == 1 ? 0 : i0 + r), 0);
          }
          combine_rows(scratch, i0, m, brackets, 1, k_level[0].data(), k_level[1].data());
          return;
        }
      }
    }
    // Per level slot: the rows it is drawn for (compacted, without a branch per row: every row is
    // written, the slot advances when drawn), their trials and p.
    for (std::size_t r = 0; r < m; ++r) {
      const double pi = p[i0 + r];
      for (int j = 0; j < 2; ++j) {
        const std::size_t q = drawn_at[j];
        rows[j][q] = r;
        n[j][q] = trials_of[j][r];
        pp[j][q] = pi;
        drawn_at[j] = q + static_cast<std::size_t>(trials_of[j][r] > 0);
      }
    }
    for (int j = 0; j < 2; ++j) {
      rows[j].resize(drawn_at[j]);
      n[j].resize(drawn_at[j]);
      pp[j].resize(drawn_at[j]);
    }
    for (int j = 0; j < 2; ++j) u[j].resize(drawn_at[j] * k);
    // A chunk whose levels span a few indices (footprints within a few levels of each other): one
    // block of vectorized Philox rows per level of the span (uninitialized: every row is written),
    // each row then picking its level's block.
    if (kIndexCells && k > 0 && level_min <= level_max && level_max - level_min < kMaxVectorLevels) {
      const std::size_t stride = m * k;
      const auto span = static_cast<std::size_t>(level_max - level_min + 1);
      scratch.blocks.resize(span * stride);
      double* const blocks = scratch.blocks.data();
      for (std::size_t l = 0; l < span; ++l)
        detail::philox_uniform_rows_level(seed, level_key(level_min + static_cast<int>(l)), kStreamLevelCount, i0, m,
                                          static_cast<int>(k), blocks + l * stride);
      for (int j = 0; j < 2; ++j) {
        double* dst = u[j].data();
        for (std::size_t q = 0; q < rows[j].size(); ++q) {
          const std::size_t r = rows[j][q];
          const auto l = static_cast<std::size_t>(brackets[r].lo + j - level_min);
          const double* src = blocks + l * stride + r * k;
          for (std::size_t d = 0; d < k; ++d) dst[q * k + d] = src[d];
        }
      }
    } else {
      for (int j = 0; j < 2; ++j) {
        for (std::size_t q = 0; q < rows[j].size(); ++q) {
          const std::size_t r = rows[j][q], i = i0 + r;
          const int level = brackets[r].lo + j;
          const auto [cx, cy] = cell_of(i, j == 0 ? brackets[r].area_lo : brackets[r].area_hi);
          CounterRng rng(seed, cx, cy, level_key(level), kStreamLevelCount);
          for (std::size_t d = 0; d < k; ++d) u[j][q * k + d] = rng.uniform();
        }
      }
    }
    auto& group_of = scratch.group_of;
    auto& order = scratch.order;
    auto& group_u = scratch.group_u;
    auto& group_k = scratch.group_k;
    for (int j = 0; j < 2; ++j) {
      const std::size_t drawn = rows[j].size();
      kk[j].resize(drawn);
      if (drawn == 0) continue;
      // Rows of a level taking a few distinct (n, p) are evaluated group by group with a fixed
      // evaluator, kept for the whole call: every rule but distributed draws N A_l trials, one n per
      // level index, so with one p a level's rows form a group per level index (and runs of equal P
      // do too). Otherwise the per-pixel path.
      constexpr std::size_t kMaxGroups = 4;
      std::array<double, kMaxGroups> group_n, group_p;
      group_n.fill(std::numeric_limits<double>::quiet_NaN());  // matches nothing
      group_p.fill(std::numeric_limits<double>::quiet_NaN());
      std::size_t groups = 0;
      bool grouped = inner_.fixed_evaluator != nullptr && drawn >= kTabulateMinBatch;
      if (grouped) {
        group_of.resize(drawn);
        for (std::size_t q = 0; q < drawn; ++q) {
          // Which group matches, without a branch per candidate (rows of different levels interleave
          // at random): a new group is the rare, predictable branch.
          unsigned match = 0;
          for (std::size_t g = 0; g < kMaxGroups; ++g)
            match |= static_cast<unsigned>(group_n[g] == n[j][q] && group_p[g] == pp[j][q]) << g;
          if (match == 0) [[unlikely]] {
            if (groups == kMaxGroups) {
              grouped = false;
              break;
            }
            group_n[groups] = n[j][q];
            group_p[groups] = pp[j][q];
            match = 1u << groups++;
          }
          group_of[q] = static_cast<std::uint8_t>(std::countr_zero(match));
        }
      }
      if (grouped && groups == 1) {
        cache.get(inner_, group_n[0], group_p[0], count)->evaluate(u[j].data(), drawn, kk[j].data());
      } else if (grouped) {
        // Rows ordered by group (a counting sort: no branch per row), each group's uniforms contiguous.
        std::array<std::size_t, kMaxGroups + 1> first{};
        for (std::size_t q = 0; q < drawn; ++q) ++first[group_of[q] + 1u];
        for (std::size_t g = 0; g < kMaxGroups; ++g) first[g + 1] += first[g];
        std::array<std::size_t, kMaxGroups> next;
        std::copy(first.begin(), first.end() - 1, next.begin());
        order.resize(drawn);
        for (std::size_t q = 0; q < drawn; ++q) order[next[group_of[q]]++] = q;
        group_u.resize(drawn * k);
        group_k.resize(drawn);
        for (std::size_t t = 0; t < drawn; ++t)
          for (std::size_t d = 0; d < k; ++d) group_u[t * k + d] = u[j][order[t] * k + d];
        for (std::size_t g = 0; g < groups; ++g)
          cache.get(inner_, group_n[g], group_p[g], count)
              ->evaluate(group_u.data() + first[g] * k, first[g + 1] - first[g], group_k.data() + first[g]);
        for (std::size_t t = 0; t < drawn; ++t) kk[j][order[t]] = group_k[t];
      } else {
        inner_.evaluate(n[j].data(), pp[j].data(), u[j].data(), drawn, kk[j].data());
      }
      check_finite(kk[j].data(), drawn, n[j].data(), pp[j].data(), 1);
      for (std::size_t q = 0; q < drawn; ++q) k_level[j][rows[j][q]] = kk[j][q];
    }
    combine_rows(scratch, i0, m, brackets, 1, k_level[0].data(), k_level[1].data());
  };
  if (inner_.thread_safe) {
    detail::parallel_chunks(count, kChunk, kChunk, chunk_body);
  } else {
    for (std::size_t i0 = 0; i0 < count; i0 += kChunk) chunk_body(i0, std::min(count, i0 + kChunk));
  }
  if (const std::size_t i = first_refused.load(); i < count) {
    check_sample(i);
    throw std::logic_error(where + ": sample " + std::to_string(i) + " was refused but passes its checks");
  }
}

namespace {
// sample()'s cells: sample i sits in cell (i mod 2^32, i >> 32) at every level, the layout of the
// vectorized Philox rows (kIndexCells tells run() so).
struct IndexCells {
  static constexpr bool kIndexCells = true;
  std::pair<std::uint32_t, std::uint32_t> operator()(std::size_t i, double) const {
    return {static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(static_cast<std::uint64_t>(i) >> 32)};
  }
};
}  // namespace

void BlendedLaw::sample(double density, ParamArray area, ParamArray p, std::size_t count, std::uint64_t seed,
                        double* out) const {
  run(density, area, p, count, seed, IndexCells{}, out);
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
  run(
      density, area, p, count, seed,
      [x, y](std::size_t i, double level_area) {
        // Cells of side sqrt(A_l) anchored at the origin; indices wrap modulo 2^32 in the key.
        const double side = std::sqrt(level_area);
        const auto cx = static_cast<std::int64_t>(std::floor(x[i] / side));
        const auto cy = static_cast<std::int64_t>(std::floor(y[i] / side));
        return std::pair<std::uint32_t, std::uint32_t>(static_cast<std::uint32_t>(cx), static_cast<std::uint32_t>(cy));
      },
      out);
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
