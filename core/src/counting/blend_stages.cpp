// The four stages of a blend call (glintlab/detail/blend_stages.hpp; docs/math/blends.md#blend-stages): brackets,
// trial counts, level rows, combine, and RowStreams, where the seed enters.
#include "glintlab/detail/blend_stages.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <stdexcept>

#include "glintlab/base/errors.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/detail/uniform_rows.hpp"
#include "level_brackets.hpp"

namespace glintlab::detail::blend_stages {

// ---------------------------------------------------------------------------------------------
// RowStreams: the seed

std::pair<std::uint32_t, std::uint32_t> RowStreams::cell(std::size_t i, double level_area) const {
  if (indexed())
    return {static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(static_cast<std::uint64_t>(i) >> 32)};
  // Cells of side sqrt(A_l) anchored at the origin; indices wrap modulo 2^32 in the key.
  const double side = std::sqrt(level_area);
  const auto cx = static_cast<std::int64_t>(std::floor(x_[i] / side));
  const auto cy = static_cast<std::int64_t>(std::floor(y_[i] / side));
  return {static_cast<std::uint32_t>(cx), static_cast<std::uint32_t>(cy)};
}

CounterRng RowStreams::generator(std::size_t i, int level, double level_area, Stream stream) const {
  const auto [cx, cy] = cell(i, level_area);
  return CounterRng(seed_, cx, cy, level_key(level), stream);
}

void RowStreams::level_rows(int level, double level_area, Stream stream, std::size_t i0, std::size_t m, int k,
                            double* out) const {
  if (k <= 0) return;
  // Index cells: the level's rows are rows of the vectorized Philox keyed at the level (the same numbers as
  // one CounterRng per cell).
  if (indexed()) return philox_uniform_rows_level(seed_, level_key(level), stream, i0, m, k, out);
  const auto kk = static_cast<std::size_t>(k);
  for (std::size_t r = 0; r < m; ++r) {
    CounterRng rng = generator(i0 + r, level, level_area, stream);
    for (std::size_t d = 0; d < kk; ++d) out[r * kk + d] = rng.uniform();
  }
}

FacetStream RowStreams::facets(std::size_t i, int level, double level_area, const double* first) const {
  const CounterRng rng = generator(i, level, level_area, kStreamLevelFacets);
  return first ? FacetStream(first, rng) : FacetStream(rng);
}

// ---------------------------------------------------------------------------------------------
// Per-thread buffers and the level evaluators

namespace {
std::vector<std::unique_ptr<ChunkScratch>>& free_scratch() {
  thread_local std::vector<std::unique_ptr<ChunkScratch>> pool;
  return pool;
}
}  // namespace

ScratchLease::ScratchLease() {
  auto& pool = free_scratch();
  if (pool.empty()) {
    held_ = std::make_unique<ChunkScratch>();
  } else {
    held_ = std::move(pool.back());
    pool.pop_back();
  }
}

ScratchLease::~ScratchLease() { free_scratch().push_back(std::move(held_)); }

std::shared_ptr<const FixedEvaluator> LevelEvaluators::get(const InnerLaw& inner, double n, double p,
                                                           std::size_t rows) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& e : entries_)
      if (e.n == n && e.p == p && e.rows >= rows) return e.evaluator;
  }
  std::shared_ptr<const FixedEvaluator> made = inner.fixed_evaluator(n, p, rows);
  const std::lock_guard<std::mutex> lock(mutex_);
  for (auto& e : entries_)
    if (e.n == n && e.p == p) {  // built for fewer rows (perhaps without a table): replaced
      if (e.rows < rows) e = {n, p, rows, made};
      return made;
    }
  if (entries_.size() < kEntries)
    entries_.push_back({n, p, rows, made});
  else
    entries_[next_++ % kEntries] = {n, p, rows, made};
  return made;
}

std::size_t LevelEvaluators::size() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

// ---------------------------------------------------------------------------------------------
// Stage 1: brackets

std::size_t bracket_rows(const LevelLadder& ladder, bool with_lod, bool one_area, const double* a, ParamArray p,
                         std::size_t i0, std::size_t m, LevelBracket* out) {
  // The checks in a pass over the rows (a per-row sequence of checks, brackets and trials mispredicted on
  // random footprints), with & so that it compiles to selects.
  auto refused = [&](std::size_t r) {
    const double area = a[one_area ? 0 : r], pi = p[i0 + r];
    return !(area > 0.0) | !(area <= std::numeric_limits<double>::max()) | !(pi >= 0.0) | !(pi <= 1.0);
  };
  // The first refused row, of the checks above or of the ladder's (a level index beyond 16 bits, which
  // bracket() throws on): rows before the first row the checks refuse may still be refused by the ladder.
  auto first_beyond_ladder = [&](std::size_t end) {
    for (std::size_t r = 0; r < end; ++r) {
      try {
        ladder.bracket(a[one_area ? 0 : r]);
      } catch (const std::invalid_argument&) { return r; }
    }
    return end;
  };
  bool any_refused = false;
  for (std::size_t r = 0; r < m; ++r) any_refused |= refused(r);
  if (any_refused) [[unlikely]] {
    std::size_t r = 0;
    while (!refused(r)) ++r;
    return first_beyond_ladder(r);
  }
  try {
    if (one_area)
      std::fill_n(out, m, ladder.bracket(a[0]));
    else if (with_lod)
      ladder.brackets(a, m, out);
    else
      ladder.brackets_without_lod(a, m, out);
  } catch (const std::invalid_argument&) { return first_beyond_ladder(m); }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Stage 2: trial counts

std::size_t trial_counts(const BlendRule& rule, double density, const double* a, const LevelBracket* b, std::size_t m,
                         const CountingLaw* law, double* t_lo, double* t_hi, LevelSpan& span) {
  rule.trials_rows(density, a, b, m, t_lo, t_hi);
  detail::snap_trial_rows(t_lo, t_hi, m);
  const double max_n = law ? law->max_n() : std::numeric_limits<double>::infinity();
  for (std::size_t r = 0; r < m; ++r) {
    // CountingLaw::accepts (p was checked by stage 1), with & so that it compiles to selects.
    const bool drawn[2] = {t_lo[r] > 0, t_hi[r] > 0};
    if (law && ((drawn[0] & !(t_lo[r] <= max_n)) | (drawn[1] & !(t_hi[r] <= max_n)))) [[unlikely]]
      return r;
    // The lowest level a row draws is lo unless it draws only the upper one; the highest is lo + 1 if it draws
    // the upper one (a row drawing neither widens the span harmlessly: no level is evaluated that no row draws).
    // Arithmetic, not a branch per row.
    span.lo = std::min(span.lo, b[r].lo + static_cast<int>(!drawn[0]));
    span.hi = std::max(span.hi, b[r].lo + static_cast<int>(drawn[1]));
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Stage 3: level rows

namespace {

constexpr int kMaxVectorLevels = 6;  // the most levels a chunk's whole-level blocks span
constexpr std::size_t kMaxGroups = 4;

// Throws, naming the first row r < m whose count is not finite, its n and p.
template <class TrialOf, class POf>
void check_counts(const double* k, std::size_t m, TrialOf n_of, POf p_of, const std::string& where) {
  for (std::size_t r = 0; r < m; ++r)
    if (!std::isfinite(k[r])) [[unlikely]]
      throw_invalid_message(where + ": the inner law returned " + format_value(k[r]) +
                            " at n = " + format_value(n_of(r)) + ", p = " + format_value(p_of(r)));
}

// out[r] = the count of row r < m at `level`, every row at (n, p): the level's uniforms for the rows, then the
// evaluator of (n, p) (a step table for long batches) or, without one, the inner law's per-pixel path.
void counts_at_one_pair(const InnerLaw& inner, const LevelLadder& ladder, const RowStreams& streams, int level,
                        double n, double p, LevelEvaluators& evaluators, std::size_t call_rows, std::size_t i0,
                        std::size_t m, ChunkScratch& s, double* out) {
  const int k = inner.n_uniforms;
  Scratch<double>& u = s.block;
  u.resize(std::max<std::size_t>(m * static_cast<std::size_t>(k), 1));
  streams.level_rows(level, ladder.area(level), kStreamLevelCount, i0, m, k, u.data());
  if (inner.fixed_evaluator) {
    evaluators.get(inner, n, p, call_rows)->evaluate(u.data(), m, out);
  } else {
    s.n[0].assign(m, n);
    s.pp[0].assign(m, p);
    inner.evaluate(s.n[0].data(), s.pp[0].data(), u.data(), m, out);
  }
}

// The (n, p) at which the rows draw each level of the span (NaN: no row draws it), when every row drawing a level
// does so at one (n, p): the rules that draw N A_l trials, with one p or runs of equal p. False when a level has two.
struct LevelPairs {
  std::array<double, kMaxVectorLevels> n, p;
};
bool one_pair_per_level(const ChunkRows& rows, LevelPairs& pairs) {
  pairs.n.fill(std::numeric_limits<double>::quiet_NaN());
  pairs.p.fill(std::numeric_limits<double>::quiet_NaN());
  const std::size_t span = rows.span.size();
  const int top = rows.span.hi - rows.span.lo;
  // Each level's (n, p) from the first row that draws it (a few rows), then every row checked against them,
  // reading only: no store in the loop, no branch per row (nearest's levels are a coin flip per row), in blocks
  // of 64 rows, leaving at the first block with a second (n, p) (distributed).
  std::size_t found = 0;
  for (std::size_t r = 0; r < rows.m && found < span; ++r) {
    for (int j = 0; j < 2; ++j) {
      const double t = rows.trial(j, r);
      const auto l = static_cast<std::size_t>(rows.bracket(r).lo + j - rows.span.lo);
      if (t > 0 && pairs.n[l] != pairs.n[l]) {
        pairs.n[l] = t;
        pairs.p[l] = rows.p[rows.i0 + r];
        ++found;
      }
    }
  }
  bool one_pair = true;
  for (std::size_t r0 = 0; r0 < rows.m && one_pair; r0 += 64) {
    const std::size_t r1 = std::min(rows.m, r0 + 64);
    for (int j = 0; j < 2; ++j) {
      for (std::size_t r = r0; r < r1; ++r) {
        const double t = rows.trial(j, r), pi = rows.p[rows.i0 + r];
        const auto l = static_cast<std::size_t>(std::clamp(rows.bracket(r).lo + j - rows.span.lo, 0, top));
        one_pair &= (!(t > 0)) | ((pairs.n[l] == t) & (pairs.p[l] == pi));
      }
    }
  }
  return one_pair;
}

// Every row drawing a level at the level's one (n, p): each level of the span evaluated over the whole chunk in
// place (a block of Philox rows, one evaluator), and each row picks its two levels' counts. Rows that do not draw
// level l are evaluated too (about half of them with footprints spread over two levels) and dropped: cheaper than
// gathering uniforms and scattering counts per group. Each kept count is evaluate() on the row's own uniforms.
void counts_by_whole_level(const InnerLaw& inner, const LevelLadder& ladder, const RowStreams& streams,
                           const ChunkRows& rows, const LevelPairs& pairs, LevelEvaluators& evaluators,
                           std::size_t call_rows, const std::string& where, ChunkScratch& s, double* k_level[2]) {
  const std::size_t m = rows.m, span = rows.span.size();
  const int top = rows.span.hi - rows.span.lo;
  s.counts.resize(span * m);
  double* const counts = s.counts.data();
  for (std::size_t l = 0; l < span; ++l)
    if (pairs.n[l] == pairs.n[l])  // some row draws this level
      counts_at_one_pair(inner, ladder, streams, rows.span.lo + static_cast<int>(l), pairs.n[l], pairs.p[l], evaluators,
                         call_rows, rows.i0, m, s, counts + l * m);
  for (int j = 0; j < 2; ++j) {
    double* const kj = k_level[j];
    for (std::size_t r = 0; r < m; ++r) {
      // A row that does not draw level j reads a count of the span too (in range, dropped).
      const auto l = static_cast<std::size_t>(std::clamp(rows.bracket(r).lo + j - rows.span.lo, 0, top));
      kj[r] = select(rows.trial(j, r) > 0, counts[l * m + r], 0.0);
    }
    check_counts(
        kj, m, [&](std::size_t r) { return rows.trial(j, r); }, [&](std::size_t r) { return rows.p[rows.i0 + r]; },
        where);
  }
}

// One footprint: every row draws the same levels at the same (n, p).
void counts_one_footprint(const InnerLaw& inner, const LevelLadder& ladder, const RowStreams& streams,
                          const ChunkRows& rows, LevelEvaluators& evaluators, std::size_t call_rows,
                          const std::string& where, ChunkScratch& s, double* k_level[2]) {
  const double p = rows.p[0];
  for (int j = 0; j < 2; ++j) {
    const double n = rows.trial(j, 0);
    if (!(n > 0)) {  // an undrawn level's counts are zeros
      std::fill_n(k_level[j], rows.m, 0.0);
      continue;
    }
    counts_at_one_pair(inner, ladder, streams, rows.bracket(0).lo + j, n, p, evaluators, call_rows, rows.i0, rows.m, s,
                       k_level[j]);
    check_counts(
        k_level[j], rows.m, [&](std::size_t) { return n; }, [&](std::size_t) { return p; }, where);
  }
}

// Per level slot j: the rows that draw it, compacted without a branch per row (every row is written, the slot
// advances when drawn), with their trials and p.
void compact_level_rows(const ChunkRows& rows, ChunkScratch& s) {
  std::size_t drawn_at[2] = {0, 0};
  for (int j = 0; j < 2; ++j) {
    s.rows[j].resize(rows.m);
    s.n[j].resize(rows.m);
    s.pp[j].resize(rows.m);
  }
  for (std::size_t r = 0; r < rows.m; ++r) {
    const double pi = rows.p[rows.i0 + r];
    for (int j = 0; j < 2; ++j) {
      const std::size_t q = drawn_at[j];
      s.rows[j][q] = r;
      s.n[j][q] = rows.trial(j, r);
      s.pp[j][q] = pi;
      drawn_at[j] = q + static_cast<std::size_t>(rows.trial(j, r) > 0);
    }
  }
  for (int j = 0; j < 2; ++j) {
    s.rows[j].resize(drawn_at[j]);
    s.n[j].resize(drawn_at[j]);
    s.pp[j].resize(drawn_at[j]);
  }
}

// u[j]: the uniforms of level slot j's compacted rows. A chunk whose levels span a few indices (footprints within
// a few levels of each other, index cells): one block of vectorized Philox rows per level of the span, each row
// then picking its level's; otherwise a generator per row.
void level_slot_uniforms(const LevelLadder& ladder, const RowStreams& streams, const ChunkRows& rows, std::size_t k,
                         ChunkScratch& s) {
  for (int j = 0; j < 2; ++j) s.u[j].resize(s.rows[j].size() * k);
  if (streams.indexed() && k > 0 && !rows.span.empty() && rows.span.size() <= kMaxVectorLevels) {
    const std::size_t stride = rows.m * k, span = rows.span.size();
    s.blocks.resize(span * stride);
    double* const blocks = s.blocks.data();
    for (std::size_t l = 0; l < span; ++l) {
      const int level = rows.span.lo + static_cast<int>(l);
      streams.level_rows(level, ladder.area(level), kStreamLevelCount, rows.i0, rows.m, static_cast<int>(k),
                         blocks + l * stride);
    }
    for (int j = 0; j < 2; ++j) {
      double* dst = s.u[j].data();
      for (std::size_t q = 0; q < s.rows[j].size(); ++q) {
        const std::size_t r = s.rows[j][q];
        const auto l = static_cast<std::size_t>(rows.bracket(r).lo + j - rows.span.lo);
        const double* src = blocks + l * stride + r * k;
        for (std::size_t d = 0; d < k; ++d) dst[q * k + d] = src[d];
      }
    }
    return;
  }
  for (int j = 0; j < 2; ++j) {
    for (std::size_t q = 0; q < s.rows[j].size(); ++q) {
      const std::size_t r = s.rows[j][q];
      const LevelBracket& b = rows.bracket(r);
      CounterRng rng = streams.generator(rows.i0 + r, b.lo + j, j == 0 ? b.area_lo : b.area_hi, kStreamLevelCount);
      for (std::size_t d = 0; d < k; ++d) s.u[j][q * k + d] = rng.uniform();
    }
  }
}

// Which of at most kMaxGroups distinct (n, p) each compacted row of slot j has (group_of), and the groups'
// (n, p); false when there are more (or no fixed evaluator, or too few rows to pay for one).
bool group_level_rows(const InnerLaw& inner, int j, ChunkScratch& s, std::array<double, kMaxGroups>& group_n,
                      std::array<double, kMaxGroups>& group_p, std::size_t& groups) {
  const std::size_t drawn = s.rows[j].size();
  group_n.fill(std::numeric_limits<double>::quiet_NaN());  // matches nothing
  group_p.fill(std::numeric_limits<double>::quiet_NaN());
  groups = 0;
  if (!inner.fixed_evaluator || drawn < kTabulateMinBatch) return false;
  s.group_of.resize(drawn);
  for (std::size_t q = 0; q < drawn; ++q) {
    // Which group matches, without a branch per candidate (rows of different levels interleave at random): a
    // new group is the rare, predictable branch.
    unsigned match = 0;
    for (std::size_t g = 0; g < kMaxGroups; ++g)
      match |= static_cast<unsigned>(group_n[g] == s.n[j][q] && group_p[g] == s.pp[j][q]) << g;
    if (match == 0) [[unlikely]] {
      if (groups == kMaxGroups) return false;
      group_n[groups] = s.n[j][q];
      group_p[groups] = s.pp[j][q];
      match = 1u << groups++;
    }
    s.group_of[q] = static_cast<std::uint8_t>(std::countr_zero(match));
  }
  return true;
}

// kk[j]: the counts of level slot j's compacted rows. Rows taking a few distinct (n, p) are evaluated group by
// group with a fixed evaluator, kept for the whole call: every rule but distributed draws N A_l trials, one n per
// level index, so with one p a level's rows form a group per level index (and runs of equal P do too). Otherwise
// the per-pixel path.
void evaluate_level_slot(const InnerLaw& inner, int j, std::size_t k, LevelEvaluators& evaluators,
                         std::size_t call_rows, ChunkScratch& s) {
  const std::size_t drawn = s.rows[j].size();
  s.kk[j].resize(drawn);
  if (drawn == 0) return;
  std::array<double, kMaxGroups> group_n, group_p;
  std::size_t groups = 0;
  if (!group_level_rows(inner, j, s, group_n, group_p, groups)) {
    inner.evaluate(s.n[j].data(), s.pp[j].data(), s.u[j].data(), drawn, s.kk[j].data());
  } else if (groups == 1) {
    evaluators.get(inner, group_n[0], group_p[0], call_rows)->evaluate(s.u[j].data(), drawn, s.kk[j].data());
  } else {
    // Rows ordered by group (a counting sort: no branch per row), each group's uniforms contiguous.
    std::array<std::size_t, kMaxGroups + 1> first{};
    for (std::size_t q = 0; q < drawn; ++q) ++first[s.group_of[q] + 1u];
    for (std::size_t g = 0; g < kMaxGroups; ++g) first[g + 1] += first[g];
    std::array<std::size_t, kMaxGroups> next;
    std::copy(first.begin(), first.end() - 1, next.begin());
    s.order.resize(drawn);
    for (std::size_t q = 0; q < drawn; ++q) s.order[next[s.group_of[q]]++] = q;
    s.group_u.resize(drawn * k);
    s.group_k.resize(drawn);
    for (std::size_t t = 0; t < drawn; ++t)
      for (std::size_t d = 0; d < k; ++d) s.group_u[t * k + d] = s.u[j][s.order[t] * k + d];
    for (std::size_t g = 0; g < groups; ++g)
      evaluators.get(inner, group_n[g], group_p[g], call_rows)
          ->evaluate(s.group_u.data() + first[g] * k, first[g + 1] - first[g], s.group_k.data() + first[g]);
    for (std::size_t t = 0; t < drawn; ++t) s.kk[j][s.order[t]] = s.group_k[t];
  }
}

// Rows with their own (n, p) per level: each level slot's rows compacted, their uniforms gathered, evaluated, and
// scattered back (rows that do not draw a level keep a count of 0).
void counts_by_row(const InnerLaw& inner, const LevelLadder& ladder, const RowStreams& streams, const ChunkRows& rows,
                   LevelEvaluators& evaluators, std::size_t call_rows, const std::string& where, ChunkScratch& s,
                   double* k_level[2]) {
  const auto k = static_cast<std::size_t>(inner.n_uniforms);
  compact_level_rows(rows, s);
  level_slot_uniforms(ladder, streams, rows, k, s);
  for (int j = 0; j < 2; ++j) {
    std::fill_n(k_level[j], rows.m, 0.0);
    evaluate_level_slot(inner, j, k, evaluators, call_rows, s);
    const std::size_t drawn = s.rows[j].size();
    check_counts(
        s.kk[j].data(), drawn, [&](std::size_t q) { return s.n[j][q]; }, [&](std::size_t q) { return s.pp[j][q]; },
        where);
    for (std::size_t q = 0; q < drawn; ++q) k_level[j][s.rows[j][q]] = s.kk[j][q];
  }
}

}  // namespace

void level_counts(const InnerLaw& inner, const LevelLadder& ladder, const RowStreams& streams, const ChunkRows& rows,
                  LevelEvaluators& evaluators, std::size_t call_rows, const std::string& where, ChunkScratch& scratch,
                  double* k_lo, double* k_hi) {
  double* k_level[2] = {k_lo, k_hi};
  if (rows.one_footprint())
    return counts_one_footprint(inner, ladder, streams, rows, evaluators, call_rows, where, scratch, k_level);
  // Whole levels where every row drawing a level shares its (n, p): sample()'s index cells (their rows are
  // vectorized Philox blocks), a built-in law, a chunk over a few levels.
  const bool whole_levels = streams.indexed() && inner.n_uniforms > 0 && !rows.span.empty() &&
                            rows.span.size() <= kMaxVectorLevels && inner.fixed_evaluator &&
                            rows.m >= kTabulateMinBatch;
  LevelPairs pairs;
  if (whole_levels && one_pair_per_level(rows, pairs))
    return counts_by_whole_level(inner, ladder, streams, rows, pairs, evaluators, call_rows, where, scratch, k_level);
  counts_by_row(inner, ladder, streams, rows, evaluators, call_rows, where, scratch, k_level);
}

// ---------------------------------------------------------------------------------------------
// Stage 4: combine

namespace {

// The first Philox block of each row's facet stream at each level the chunk spans (index cells, a rule that
// thins), computed ahead as vectorized rows: a scalar Philox block per row and level was most of the roulette's
// cost. Returns the blocks (row r of level span.lo + l at [(l m + r) 2]) and sets lo to the span's lowest level;
// null where none are computed (a span too wide, other cells).
const double* facet_first_blocks(const RowStreams& streams, const ChunkRows& rows, std::array<bool, 2> drawn,
                                 ChunkScratch& s, int& lo) {
  constexpr int kMaxFacetLevels = 7;
  if (!streams.indexed() || rows.m == 0) return nullptr;
  int lmin = std::numeric_limits<int>::max(), lmax = std::numeric_limits<int>::min();
  for (std::size_t r = 0; r < rows.m; ++r) {
    const int l = rows.bracket(r).lo;
    lmin = std::min(lmin, l);
    lmax = std::max(lmax, l + 1);
    if (rows.one_footprint()) break;
  }
  if (lmax - lmin >= kMaxFacetLevels) return nullptr;
  lo = lmin;
  const auto span = static_cast<std::size_t>(lmax - lmin + 1);
  s.first_blocks.resize(span * rows.m * 2);
  for (std::size_t l = 0; l < span; ++l) {
    const int level = lmin + static_cast<int>(l);
    if (rows.one_footprint() && !drawn[static_cast<std::size_t>(level - rows.bracket(0).lo)]) continue;
    streams.level_rows(level, std::numeric_limits<double>::quiet_NaN(), kStreamLevelFacets, rows.i0, rows.m, 2,
                       s.first_blocks.data() + l * rows.m * 2);
  }
  return s.first_blocks.data();
}

}  // namespace

void combine_levels(const BlendRule& rule, const RowStreams& streams, const ChunkRows& rows, const double* k_lo,
                    const double* k_hi, ChunkScratch& s, double* out) {
  const std::size_t m = rows.m;
  // For one footprint, which levels have trials (an undrawn level's facets are never read).
  const std::array<bool, 2> drawn = rows.one_footprint()
                                        ? std::array<bool, 2>{rows.trial(0, 0) > 0, rows.trial(1, 0) > 0}
                                        : std::array<bool, 2>{true, true};
  int lo = 0;
  const double* first = rule.thins() ? facet_first_blocks(streams, rows, drawn, s, lo) : nullptr;
  BlendRule::FacetRows facets;
  if (rows.one_footprint()) {
    // One bracket for every row: the rule's batch form (the same bits as combine() per row).
    const LevelBracket& b = rows.bracket(0);
    if (first)
      for (std::size_t j = 0; j < 2; ++j)
        if (drawn[j]) facets.first[j] = first + static_cast<std::size_t>(b.lo + static_cast<int>(j) - lo) * m * 2;
  } else if (first) {
    // A bracket per row: each row's first blocks gathered into the layout of the one-bracket form, so that a
    // rule's combine_rows_each reads them as combine_rows does.
    s.gathered.resize(4 * m);
    for (std::size_t j = 0; j < 2; ++j) {
      double* dst = s.gathered.data() + j * 2 * m;
      for (std::size_t r = 0; r < m; ++r) {
        const auto l = static_cast<std::size_t>(rows.bracket(r).lo + static_cast<int>(j) - lo);
        dst[2 * r] = first[(l * m + r) * 2];
        dst[2 * r + 1] = first[(l * m + r) * 2 + 1];
      }
      facets.first[j] = dst;
    }
  }
  facets.stream = [&](std::size_t r, int j) {
    const LevelBracket& b = rows.bracket(r);
    const double* block = facets.first[static_cast<std::size_t>(j)];
    return streams.facets(rows.i0 + r, b.lo + j, j == 0 ? b.area_lo : b.area_hi, block ? block + 2 * r : nullptr);
  };
  if (rows.one_footprint())
    rule.combine_rows(rows.areas[0], rows.bracket(0), m, k_lo, k_hi, facets, out);
  else
    rule.combine_rows_each(rows.areas, rows.brackets, m, k_lo, k_hi, facets, out);
}

}  // namespace glintlab::detail::blend_stages
