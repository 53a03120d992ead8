#include "glintlab/blend.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "glintlab/binomial.hpp"
#include "glintlab/errors.hpp"
#include "parallel.hpp"

namespace glintlab {

namespace {

// Level l's 16-bit key in the counter (two's complement, so negative levels are distinct).
std::uint16_t level_key(int level) { return static_cast<std::uint16_t>(static_cast<std::int16_t>(level)); }

constexpr std::size_t kChunk = 2048;

// A rule's trial counts come from products of areas and densities, which land a few ulps off the
// integers they stand for (N A_hi = n (A_hi / P) at P one ulp below A_hi; w N A_hi at w = 1e-16).
// Left alone, the stratified rule turns such an ulp into a Bernoulli facet, so K could reach
// ceil(n) + 1 (found by the extremes suite). Counts within 4 ulps of the pair's total from an
// integer are that integer; elsewhere the counts are untouched.
std::array<double, 2> snap_trials(std::array<double, 2> t) {
  const double tolerance = 4 * std::numeric_limits<double>::epsilon() * (std::abs(t[0]) + std::abs(t[1]));
  for (double& x : t) {
    const double r = std::round(x);
    if (std::abs(x - r) <= tolerance) x = r;
  }
  return t;
}

// Fixed evaluators of the (n, p) pairs that whole chunks share (runs of equal P and p in arrays),
// kept for the chunks that follow, since a run usually spans several. Shared by the threads of one
// call; a few entries, the oldest replaced.
class FixedEvaluatorCache {
 public:
  std::shared_ptr<const FixedEvaluator> get(const InnerLaw& inner, double n, double p, std::size_t rows) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& e : entries_)
        if (e.n == n && e.p == p) return e.evaluator;
    }
    std::shared_ptr<const FixedEvaluator> made = inner.fixed_evaluator(n, p, rows);
    const std::lock_guard<std::mutex> lock(mutex_);
    if (entries_.size() < kEntries) entries_.push_back({n, p, made});
    else entries_[next_++ % kEntries] = {n, p, made};
    return made;
  }

 private:
  static constexpr std::size_t kEntries = 8;
  struct Entry {
    double n, p;
    std::shared_ptr<const FixedEvaluator> evaluator;
  };
  std::mutex mutex_;
  std::vector<Entry> entries_;
  std::size_t next_ = 0;
};

}  // namespace

LevelLadder::LevelLadder(double ratio, double base_area) : ratio_(ratio), base_area_(base_area), log_ratio_(0.0) {
  if (!(ratio > 1.0) || !std::isfinite(ratio))
    throw_invalid("blended_law", "level_ratio", ratio, "a finite number > 1 (4 for mip levels)");
  if (!(base_area > 0.0) || !std::isfinite(base_area))
    throw_invalid("blended_law", "base_area", base_area, "a finite area > 0");
  log_ratio_ = std::log(ratio_);
  areas_.resize(2 * kTabulated + 1);
  for (int l = -kTabulated; l <= kTabulated; ++l)
    areas_[static_cast<std::size_t>(l + kTabulated)] = base_area_ * std::pow(ratio_, l);
  increasing_ = std::adjacent_find(areas_.begin(), areas_.end(), std::greater_equal<double>()) == areas_.end();
}

LevelBracket LevelLadder::bracket(double footprint_area) const {
  const double a = footprint_area;
  if (!(a > 0.0) || !std::isfinite(a)) throw_invalid("blended_law", "P", a, "a finite footprint area > 0");
  if (increasing_ && a >= areas_.front() && a < areas_.back()) {
    // Inside the table the level is its unique A_lo <= P < A_hi (the areas increase strictly), the
    // one the logarithm and the settling steps below find: a branch-free bisection finds it without
    // the logarithm.
    std::size_t at = 0, span = areas_.size() - 1;  // areas_[at] <= a < areas_[at + span]
    while (span > 1) {
      const std::size_t half = span / 2;
      at = areas_[at + half] <= a ? at + half : at;
      span -= half;
    }
    return bracket_at(a, static_cast<int>(at) - kTabulated);
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

LevelBracket LevelLadder::bracket_at(double a, int lo) const {
  LevelBracket b;
  b.lo = lo;
  b.area_lo = area(lo);
  b.area_hi = area(lo + 1);
  b.w_lod = std::clamp(std::log(a / b.area_lo) / log_ratio_, 0.0, std::nextafter(1.0, 0.0));
  b.w_area = std::clamp((a - b.area_lo) / (b.area_hi - b.area_lo), 0.0, std::nextafter(1.0, 0.0));
  return b;
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
    raw->evaluate_pixels(n, p, u, m, out);
  };
  inner.fixed_evaluator = [raw](double n, double p, std::size_t rows) { return raw->fixed_evaluator(n, p, rows); };
  inner.law = std::move(law);
  return inner;
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

std::string BlendedLaw::binning() const {
  return rule_->integer_output() && inner_.integer_output ? "none" : "round";
}

bool BlendedLaw::has_pmf() const {
  return rule_->has_pmf() && inner_.law && inner_.law->has_pmf() && inner_.integer_output;
}

double BlendedLaw::variance_ratio(double area) const {
  return rule_->variance_ratio(area, ladder_.bracket(area));
}

Distribution BlendedLaw::pmf(double density, double area, double p, std::size_t max_support) const {
  const std::string where = "blended_law('" + rule_->name() + "', inner='" + inner_.name + "')";
  check_n(where, density, "N");
  check_p(where, p);
  const LevelBracket b = ladder_.bracket(area);
  if (!has_pmf())
    throw not_implemented(where + " has no exact distribution: " +
                          (!rule_->has_pmf() ? std::string("the blend's K has a continuous part")
                           : inner_.law && inner_.law->has_pmf() ? std::string("the inner law produces non-integer counts")
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
                              format_value(v) + " at n = " + format_value(trials[j]));
  }
  return rule_->combine_pmf(area, b, levels[0], levels[1], max_support);
}

template <class CellOf>
void BlendedLaw::run(double density, ParamArray area, ParamArray p, std::size_t count, std::uint64_t seed,
                     CellOf cell_of, double* out) const {
  const std::string where = "blended_law('" + rule_->name() + "', inner='" + inner_.name + "')";
  check_n(where, density, "N");
  if (area.size != 1 && area.size != count)
    throw std::invalid_argument(where + ": P has " + std::to_string(area.size) + " values; expected 1 or " +
                                std::to_string(count));
  if (p.size != 1 && p.size != count)
    throw std::invalid_argument(where + ": p has " + std::to_string(p.size) + " values; expected 1 or " +
                                std::to_string(count));
  // Validate everything before drawing anything: a bad element is named, no partial output.
  for (std::size_t i = 0; i < area.size; ++i) {
    const double a = area[i];
    if (!(a > 0.0) || !std::isfinite(a))
      throw_invalid(where, indexed_name("P", i, area.size > 1), a, "a finite footprint area > 0");
  }
  for (std::size_t i = 0; i < p.size; ++i) check_p(where, p[i], indexed_name("p", i, p.size > 1));
  if (inner_.law) {
    auto check_trials = [&](std::size_t i) {
      const LevelBracket b = ladder_.bracket(area[i]);
      const auto trials = snap_trials(rule_->trials(density, area[i], b));
      for (double t : trials)
        if (t > 0 && !inner_.law->accepts(t, p[i]))
          throw std::invalid_argument(where + ": the inner law refuses its trial count n = " + format_value(t) +
                                      " at p = " + format_value(p[i]) + " (P = " + format_value(area[i]) + ")");
    };
    // On every thread; the lowest bad index is then checked again to throw its own message, as a
    // serial pass would.
    const std::size_t m = std::max(area.size, p.size);
    std::atomic<std::size_t> first_bad{m};
    detail::parallel_chunks(m, kChunk, kChunk, [&](std::size_t i0, std::size_t i1) {
      for (std::size_t i = i0; i < i1; ++i) {
        try {
          check_trials(i);
        } catch (const std::exception&) {
          std::size_t seen = first_bad.load();
          while (i < seen && !first_bad.compare_exchange_weak(seen, i)) {
          }
          return;
        }
      }
    });
    if (first_bad.load() < m) check_trials(first_bad.load());
  }

  const std::size_t k = static_cast<std::size_t>(inner_.n_uniforms);
  const bool thins = rule_->thins();
  // Sample i's cells are (i mod 2^32, i >> 32) at every level (sample(), not sample_at()): the
  // level's uniforms are then rows of the vectorized Philox keyed at that level (the same numbers as
  // one CounterRng per cell).
  constexpr bool kIndexCells = requires { CellOf::kIndexCells; };
  auto check_finite = [&](const double* kk, std::size_t rows, const double* n, const double* pp) {
    for (std::size_t q = 0; q < rows; ++q)
      if (!std::isfinite(kk[q]))
        throw std::invalid_argument(where + ": the inner law returned " + format_value(kk[q]) + " at n = " +
                                    format_value(n[q]) + ", p = " + format_value(pp[q]));
  };
  // The level counts into K; the facet streams only for rules that thin (roulette).
  auto combine_rows = [&](std::size_t i0, std::size_t m, const LevelBracket* brackets, std::size_t bracket_step,
                          const double* k_lo, const double* k_hi) {
    std::array<CounterRng, 2> facets = {CounterRng(seed, 0, 0), CounterRng(seed, 0, 0)};
    for (std::size_t r = 0; r < m; ++r) {
      const std::size_t i = i0 + r;
      const LevelBracket& b = brackets[r * bracket_step];
      if (thins) {
        for (int j = 0; j < 2; ++j) {
          const auto [cx, cy] = cell_of(i, j == 0 ? b.area_lo : b.area_hi);
          facets[static_cast<std::size_t>(j)] = CounterRng(seed, cx, cy, level_key(b.lo + j), kStreamLevelFacets);
        }
      }
      out[i] = rule_->combine(area[i], b, k_lo[r], k_hi[r], facets);
    }
  };

  // One footprint area and one p for the whole batch (a flat patch, a study at one P): one bracket,
  // one pair of trial counts, and each drawn level at one (n, p), evaluated by the inner law's fixed
  // evaluator (a table built once for the batch where the law has one) instead of per pixel.
  if (area.size == 1 && p.size == 1) {
    const LevelBracket b = ladder_.bracket(area[0]);
    const auto trials = snap_trials(rule_->trials(density, area[0], b));
    std::unique_ptr<FixedEvaluator> evaluators[2];
    for (int j = 0; j < 2; ++j)
      if (trials[j] > 0 && inner_.fixed_evaluator) evaluators[j] = inner_.fixed_evaluator(trials[j], p[0], count);
    auto chunk_body = [&](std::size_t i0, std::size_t i1) {
      const std::size_t m = i1 - i0;
      std::vector<double> u(m * k), k_level[2], n_rows, p_rows;
      for (int j = 0; j < 2; ++j) {
        k_level[j].assign(m, 0.0);
        if (!(trials[j] > 0)) continue;
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
        n_rows.assign(m, trials[j]);
        p_rows.assign(m, p[0]);
        if (evaluators[j]) evaluators[j]->evaluate(u.data(), m, k_level[j].data());
        else inner_.evaluate(n_rows.data(), p_rows.data(), u.data(), m, k_level[j].data());
        check_finite(k_level[j].data(), m, n_rows.data(), p_rows.data());
      }
      combine_rows(i0, m, &b, 0, k_level[0].data(), k_level[1].data());
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
  FixedEvaluatorCache cache;
  auto chunk_body = [&](std::size_t i0, std::size_t i1) {
    const std::size_t m = i1 - i0;
    std::vector<LevelBracket> brackets(m);
    // Per level: the rows it is drawn for (compacted), their trials, p, uniforms and counts.
    std::vector<std::size_t> rows[2];
    std::vector<double> n[2], pp[2], u[2], kk[2];
    std::vector<double> k_level[2] = {std::vector<double>(m, 0.0), std::vector<double>(m, 0.0)};
    for (int j = 0; j < 2; ++j) {
      rows[j].reserve(m);
      n[j].reserve(m);
      pp[j].reserve(m);
      u[j].reserve(m * k);
    }
    constexpr std::size_t kMaxVectorLevels = 6;
    std::vector<int> levels;  // distinct levels drawn in this chunk (index cells only)
    bool vector_rows = kIndexCells && k > 0;
    for (std::size_t r = 0; r < m; ++r) {
      const std::size_t i = i0 + r;
      brackets[r] = ladder_.bracket(area[i]);
      const auto trials = snap_trials(rule_->trials(density, area[i], brackets[r]));
      for (int j = 0; j < 2; ++j) {
        if (!(trials[j] > 0)) continue;
        const int level = brackets[r].lo + j;
        rows[j].push_back(r);
        n[j].push_back(trials[j]);
        pp[j].push_back(p[i]);
        if (vector_rows) {
          if (std::find(levels.begin(), levels.end(), level) == levels.end()) levels.push_back(level);
          vector_rows = levels.size() <= kMaxVectorLevels;
        }
      }
    }
    if (vector_rows) {
      // One block of rows per distinct level (uninitialized: every row is written), then one pass per
      // level slot j picking each row's level.
      const std::size_t stride = m * k;
      const std::unique_ptr<double[]> blocks(new double[levels.size() * stride]);
      for (std::size_t l = 0; l < levels.size(); ++l)
        detail::philox_uniform_rows_level(seed, level_key(levels[l]), kStreamLevelCount, i0, m, static_cast<int>(k),
                                          blocks.get() + l * stride);
      for (int j = 0; j < 2; ++j) {
        u[j].resize(rows[j].size() * k);
        for (std::size_t q = 0; q < rows[j].size(); ++q) {
          const std::size_t r = rows[j][q];
          const int level = brackets[r].lo + j;
          std::size_t l = 0;
          while (levels[l] != level) ++l;
          const double* src = blocks.get() + l * stride + r * k;
          for (std::size_t d = 0; d < k; ++d) u[j][q * k + d] = src[d];
        }
      }
    } else {
      for (int j = 0; j < 2; ++j) {
        for (const std::size_t r : rows[j]) {
          const std::size_t i = i0 + r;
          const int level = brackets[r].lo + j;
          const auto [cx, cy] = cell_of(i, j == 0 ? brackets[r].area_lo : brackets[r].area_hi);
          CounterRng rng(seed, cx, cy, level_key(level), kStreamLevelCount);
          for (std::size_t d = 0; d < k; ++d) u[j].push_back(rng.uniform());
        }
      }
    }
    for (int j = 0; j < 2; ++j) {
      const std::size_t drawn = rows[j].size();
      kk[j].resize(drawn);
      if (drawn == 0) continue;
      const bool one_np = inner_.fixed_evaluator && drawn >= kTabulateMinBatch &&
                          std::all_of(n[j].begin(), n[j].end(), [&](double v) { return v == n[j][0]; }) &&
                          std::all_of(pp[j].begin(), pp[j].end(), [&](double v) { return v == pp[j][0]; });
      if (one_np) cache.get(inner_, n[j][0], pp[j][0], drawn)->evaluate(u[j].data(), drawn, kk[j].data());
      else inner_.evaluate(n[j].data(), pp[j].data(), u[j].data(), drawn, kk[j].data());
      check_finite(kk[j].data(), drawn, n[j].data(), pp[j].data());
      for (std::size_t q = 0; q < drawn; ++q) k_level[j][rows[j][q]] = kk[j][q];
    }
    combine_rows(i0, m, brackets.data(), 1, k_level[0].data(), k_level[1].data());
  };
  if (inner_.thread_safe) {
    detail::parallel_chunks(count, kChunk, kChunk, chunk_body);
  } else {
    for (std::size_t i0 = 0; i0 < count; i0 += kChunk) chunk_body(i0, std::min(count, i0 + kChunk));
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

void BlendedLaw::sample_at(double density, ParamArray area, ParamArray p, ParamArray x, ParamArray y,
                           std::size_t count, std::uint64_t seed, double* out) const {
  const std::string where = "blended_law('" + rule_->name() + "').sample_at";
  for (auto [name, arr] : {std::pair<const char*, ParamArray>{"x", x}, {"y", y}}) {
    if (arr.size != 1 && arr.size != count)
      throw std::invalid_argument(where + ": " + name + " has " + std::to_string(arr.size) +
                                  " values; expected 1 or " + std::to_string(count));
    for (std::size_t i = 0; i < arr.size; ++i)
      if (!std::isfinite(arr[i]) || std::abs(arr[i]) > 1e9)
        throw_invalid(where, indexed_name(name, i, arr.size > 1), arr[i], "a finite texture coordinate, |x| <= 1e9");
  }
  run(density, area, p, count, seed,
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
    throw std::invalid_argument("roulette pmf: the law needs more than max_support = " + std::to_string(max_support) +
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
