// The stages of BlendedLaw::sample and sample_at (core/src/counting/blend_stages.cpp;
// docs/math/blends.md#blend-stages): internal to the library and its tests. A call cuts its samples into chunks of
// rows; each chunk goes through
//
//   1. brackets       bracket_rows   each row's P and p checked, its level bracket on the ladder
//   2. trial counts   trial_counts   the rule's trials at the two levels, snapped, checked against the inner law
//   3. level rows     level_counts   each level's count: the inner law on the level cell's random numbers
//   4. combine        combine_levels the rule's K from the two level counts (and, for the roulette, facet streams)
//
// with one footprint area and one p for the whole call (a flat patch, a study at one P), stages 1 and 2 run once
// for the call and every chunk shares their bracket and trials (ChunkRows::one_footprint()).
//
// The seed enters at one place, RowStreams: stage 3 reads the levels' count uniforms from it, stage 4 the facet
// streams; nothing else sees the seed. Every random number is a pure function of (seed, the row's cell at the
// level, the level, the stream), so results do not depend on the chunking, the thread count or the path taken.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "glintlab/base/rng.hpp"
#include "glintlab/counting/blend.hpp"
#include "glintlab/counting/law.hpp"

namespace glintlab::detail {
class FixedEvaluator;
}

namespace glintlab::detail::blend_stages {

// Level l's 16-bit key in the counter (two's complement, so negative levels are distinct).
inline std::uint16_t level_key(int level) { return static_cast<std::uint16_t>(static_cast<std::int16_t>(level)); }

// Where each sample sits at each level, and the random numbers keyed there: the blend's seed and nothing else.
// sample() puts sample i in cell (i mod 2^32, i >> 32) at every level (index cells: a level's rows are then
// rows of the vectorized Philox); sample_at() in the cell of side sqrt(A_l) holding (x[i], y[i]), so nearby
// pixels share cells. The numbers of (sample i, level l, stream s) are CounterRng(seed, cell, l, s)'s.
class RowStreams {
 public:
  static RowStreams index_cells(std::uint64_t seed) { return RowStreams(seed, {nullptr, 0}, {nullptr, 0}); }
  static RowStreams positions(std::uint64_t seed, ParamArray x, ParamArray y) { return RowStreams(seed, x, y); }
  bool indexed() const { return x_.data == nullptr; }
  // Sample i's cell at a level of area `level_area`.
  std::pair<std::uint32_t, std::uint32_t> cell(std::size_t i, double level_area) const;
  // Sample i's generator at `level` (of area level_area) and stream (kStreamLevelCount: the inner law's
  // uniforms; kStreamLevelFacets: the per-facet decisions).
  CounterRng generator(std::size_t i, int level, double level_area, Stream stream) const;
  // out[r k .. r k + k) = the first k numbers of sample i0 + r's generator at `level`, for r < m: the
  // vectorized Philox rows for index cells, a generator per row otherwise.
  void level_rows(int level, double level_area, Stream stream, std::size_t i0, std::size_t m, int k, double* out) const;
  // Sample i's facet stream at `level`; first (or null): its first Philox block, computed ahead by level_rows.
  FacetStream facets(std::size_t i, int level, double level_area, const double* first) const;

 private:
  RowStreams(std::uint64_t seed, ParamArray x, ParamArray y) : seed_(seed), x_(x), y_(y) {}
  std::uint64_t seed_;
  ParamArray x_, y_;  // texture positions (sample_at); null data: index cells
};

// The levels a chunk's rows draw, lo <= l <= hi (empty: lo > hi).
struct LevelSpan {
  int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
  bool empty() const { return lo > hi; }
  std::size_t size() const { return empty() ? 0 : static_cast<std::size_t>(hi - lo + 1); }
};

// A chunk's rows as stages 3 and 4 read them: per row, or one bracket and one pair of trials for all rows.
struct ChunkRows {
  std::size_t i0 = 0, m = 0;      // the call's samples i0 .. i0 + m
  const double* areas = nullptr;  // areas[r * step]: row r's footprint area P
  const LevelBracket* brackets = nullptr;
  const double* trials[2] = {nullptr, nullptr};  // trials[j][r * step]: row r's trials at level lo + j
  std::size_t step = 1;                          // 0: one footprint (every row's P, bracket and trials are element 0)
  ParamArray p{nullptr, 0};                      // the call's p: row r's is p[i0 + r]
  LevelSpan span;                                // the levels drawn (trial_counts)

  bool one_footprint() const { return step == 0; }
  const LevelBracket& bracket(std::size_t r) const { return brackets[r * step]; }
  double trial(int j, std::size_t r) const { return trials[j][r * step]; }
};

// Buffers of a chunk uninitialized where written before read: the zero fill of std::vector's resize() showed in
// profiles (about 10 % of the instructions of a blend with P per sample).
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

// The buffers of one chunk, kept per thread across chunks and calls (ScratchLease): buffers allocated per chunk
// cost page faults (glibc returns freed memory above its trim threshold to the kernel, and takes it back zeroed),
// a quarter of a P-per-sample call's time. Every buffer is written before it is read.
struct ChunkScratch {
  Scratch<LevelBracket> brackets;
  Scratch<double> areas, t_lo, t_hi;  // stages 1 and 2
  Scratch<double> k_level[2];         // stage 3's output: each row's count at level lo + j
  // stage 3's work: rows drawn per level slot, their (n, p), uniforms and counts; whole levels' blocks; groups
  Scratch<std::size_t> rows[2], order;
  Scratch<double> n[2], pp[2], u[2], kk[2], block, counts, blocks, group_u, group_k;
  Scratch<std::uint8_t> group_of;
  Scratch<double> first_blocks, gathered;  // stage 4: the facet streams' first blocks
};

// This thread's ChunkScratch for the lease's lifetime; a nested call on the same thread (a Python inner law that
// samples a blend) leases another.
class ScratchLease {
 public:
  ScratchLease();
  ~ScratchLease();
  ScratchLease(const ScratchLease&) = delete;
  ScratchLease& operator=(const ScratchLease&) = delete;
  ChunkScratch& operator*() { return *held_; }

 private:
  std::unique_ptr<ChunkScratch> held_;
};

// The inner law's fixed evaluators (detail::FixedEvaluator: a step table where the law has one) of the (n, p) pairs
// whole levels share, kept by the BlendedLaw across chunks and calls: a run of equal P spans several chunks, and a
// renderer or a study calls again at the same footprint, where rebuilding a level's step table cost as much as
// drawing it (at 409 base cells, N = 1e4, p = 0.01: two tables of 2^18 cells, ~2 ms a call). Shared by threads
// and calls (a mutex); a few entries, the oldest replaced. Every evaluator gives evaluate()'s bits, so what the
// cache holds never changes an output.
class LevelEvaluators {
 public:
  // The evaluator of (n, p) prepared for at least `rows` rows: a kept one built for as many rows or more (a
  // table serves fewer rows as well), else a new one.
  std::shared_ptr<const FixedEvaluator> get(const InnerLaw& inner, double n, double p, std::size_t rows);
  std::size_t size() const;

 private:
  static constexpr std::size_t kEntries = 8;
  struct Entry {
    double n, p;
    std::size_t rows;
    std::shared_ptr<const FixedEvaluator> evaluator;
  };
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;
  std::size_t next_ = 0;
};

// Stage 1, brackets. Rows r < m of the call's samples i0 + r, with footprint areas a[r] (the call's, or
// one_area: a[0] for all) and probabilities p[i0 + r]: returns the first row refused (P not finite > 0, p outside
// [0, 1], or a level index beyond 16 bits), m when none; then out[r] = ladder.bracket(a[r]) for every row (w_lod
// NaN where !with_lod and the areas vary: a rule that does not read it is spared the logarithm).
std::size_t bracket_rows(const LevelLadder& ladder, bool with_lod, bool one_area, const double* a, ParamArray p,
                         std::size_t i0, std::size_t m, LevelBracket* out);

// Stage 2, trial counts. t_lo[r], t_hi[r]: the rule's trials at row r's levels lo and lo + 1, snapped to the
// integer within 4 ulps of the pair's total (a product of areas lands a few ulps off the count it stands for);
// returns the first row whose drawn trials the inner law refuses (law non-null: above its max_n, or NaN), m when
// none; span: the levels the rows draw (lo unless only the upper one, up to lo + 1 if the upper one).
std::size_t trial_counts(const BlendRule& rule, double density, const double* a, const LevelBracket* b, std::size_t m,
                         const CountingLaw* law, double* t_lo, double* t_hi, LevelSpan& span);

// Stage 3, level rows. k_lo[r], k_hi[r]: row r's counts at levels lo and lo + 1 (0 where it draws none): the inner
// law at the row's trials and p on the first n_uniforms numbers of its generator at the level, stream
// kStreamLevelCount (the only place count uniforms are drawn). Levels at one (n, p) go through a fixed evaluator
// (whole levels a block at a time, or groups of rows), the rest through the inner law's per-pixel path; the same
// bits either way. A non-finite count throws std::invalid_argument naming it, its n and p (`where` first).
void level_counts(const InnerLaw& inner, const LevelLadder& ladder, const RowStreams& streams, const ChunkRows& rows,
                  LevelEvaluators& evaluators, std::size_t call_rows, const std::string& where, ChunkScratch& scratch,
                  double* k_lo, double* k_hi);

// Stage 4, combine. out[r] = the rule's K of row r from its level counts (combine_rows for one footprint,
// combine_rows_each otherwise), with each row's facet streams at its two levels for a rule that thins (their
// first Philox blocks computed ahead for index cells).
void combine_levels(const BlendRule& rule, const RowStreams& streams, const ChunkRows& rows, const double* k_lo,
                    const double* k_hi, ChunkScratch& scratch, double* out);

}  // namespace glintlab::detail::blend_stages
