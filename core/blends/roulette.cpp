// Blend "roulette": KPT25's Russian-roulette interpolation (§3.3.3, eq. 8) in counting form. Each
// level is drawn at full density, b(N A_l, p) in its cell, and each of its reflecting facets is kept
// with the level's LOD weight (1 - w below, w above), so single glints switch on and off at full
// intensity instead of fading as in zk16_linear; K = (P / A_lo) kept_lo + (P / A_hi) kept_hi.
//
// epsilon = 0 is the hard roulette: facet i of a level is kept iff r_i < weight. The kept count is
// then Binomial(k, weight) given k, drawn by inversion from one uniform of the level cell's facet
// stream (monotone in the weight: a zoom only ever adds facets), and E[K] = N P p exactly.
// epsilon > 0 is KPT25's mollified roulette (eq. 8): facet i contributes
//   R(r_i, weight) = smoothstep(max(0, r_i - eps), min(1, r_i + eps), weight)  in [0, 1],
// with r_i the i-th uniform of the level cell's facet stream (explicit facets up to 64 per level;
// above, the sum of R over k facets is drawn as a normal with its exact mean and variance, clamped to
// [0, k]). E[R] = weight for weight in [2 eps, 1 - 2 eps], where the smoothstep's window [r - eps,
// r + eps] is never clipped to [0, 1]; nearer the ends it is not (blend_detail::roulette_moments),
// but the two levels' errors cancel: E[R(r, w)] + E[R(r, 1 - w)] = 1 for every w (R(r, w) =
// 1 - R(1 - r, 1 - w) by symmetry of the smoothstep), so E[K] = N P p at every w (tested). KPT25 use
// eps = 0.1.
// A non-integer level count k (a law with continuous output) is floor(k) facets plus one facet of
// weight frac(k).
// The moments E[R], E[R^2] are a closed form (detail/roulette.hpp; docs/math/blends.md, "Moments of R
// in closed form"); the batch forms compute the rows' normal sums in vector kernels
// (core/src/counting/roulette_rows*.cpp) with the scalar code's operations, so every path gives the same bits.
#include <boost/math/quadrature/gauss_kronrod.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <unordered_map>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/blend.hpp"
#include "glintlab/detail/roulette.hpp"
#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/normal.hpp"

namespace glintlab {

namespace blend_detail {

double roulette_keep(double r, double weight, double eps) {
  if (eps <= 0) return r < weight ? 1.0 : 0.0;
  const double e0 = std::max(0.0, r - eps), e1 = std::min(1.0, r + eps);
  // An eps below half an ulp of r leaves no window (e1 = e0): the step it tends to (0 / 0 otherwise).
  if (!(e1 > e0)) return r < weight ? 1.0 : 0.0;
  const double t = std::clamp((weight - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

std::array<double, 2> roulette_moments_quadrature(double weight, double eps) {
  if (eps <= 0) return {weight, weight};
  // R(., weight) is smooth between these breakpoints (where a clamp or the smoothstep saturates).
  std::array<double, 6> cuts = {0.0, 1.0, eps, 1.0 - eps, weight - eps, weight + eps};
  std::sort(cuts.begin(), cuts.end());
  std::array<double, 2> m = {0.0, 0.0};
  using Gk = boost::math::quadrature::gauss_kronrod<double, 31>;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double a = std::clamp(cuts[i], 0.0, 1.0), b = std::clamp(cuts[i + 1], 0.0, 1.0);
    if (!(b > a)) continue;
    m[0] += Gk::integrate([&](double r) { return roulette_keep(r, weight, eps); }, a, b, 0);
    m[1] += Gk::integrate(
        [&](double r) {
          const double v = roulette_keep(r, weight, eps);
          return v * v;
        },
        a, b, 0);
  }
  return m;
}

std::array<double, 2> roulette_moments(double weight, double eps) {
  if (eps <= 0) return {weight, weight};
  std::array<double, 2> m;
  roulette_moments_at(weight, RouletteEps(eps), m[0], m[1]);
  return m;
}

}  // namespace blend_detail

namespace {

constexpr double kExplicitFacets = detail::kRouletteExplicitFacets;

// blend_detail::thin(n, q, u) = binomial::quantile(u, n, q) for integer n > 0 and q in (0, 1), from
// this thread's tables of the (n, q) pairs met often: a batch at one footprint area thins every row
// of a level with one weight q and a few hundred distinct counts n, each a full CDF inversion
// (about 20 incomplete-beta evaluations) otherwise. binomial::QuantileTable is quantile bit for bit,
// so the bits do not depend on the cache's state (nor on the thread).
// A pair gets its table once it has been used about window / 8 times (at least 16), the window being
// the ~17 sd + 40 counts the table evaluates two tail functions at: by then the quantiles it saves
// have paid for it. The cache is emptied past kMaxPairs pairs (weights that vary per row fill it with
// pairs used once) or kMaxCounts tabulated counts in all (32-48 bytes each: under 20 MB a thread).
class ThinTables {
 public:
  double operator()(double n, double q, double u) {
    const Key key{bits(n), bits(q)};
    auto it = tables_.find(key);
    if (it == tables_.end()) {
      if (tables_.size() >= kMaxPairs) clear();
      const double window = 17.0 * std::sqrt(n * q * (1.0 - q)) + 40.0;
      it = tables_.emplace(key, Entry{0, std::max(16.0, window / 8.0), window, nullptr}).first;
    }
    Entry& e = it->second;
    if (!e.table) {
      if (static_cast<double>(++e.uses) < e.table_after) return binomial::quantile(u, n, q);
      if (counts_ + e.window > kMaxCounts) {
        clear();  // e is gone with the rest; this call answers directly, the pair starts over
        return binomial::quantile(u, n, q);
      }
      counts_ += e.window;
      e.table = std::make_unique<binomial::QuantileTable>(n, q, std::size_t{1} << 16);
    }
    return (*e.table)(u);
  }

 private:
  static constexpr std::size_t kMaxPairs = 8192;
  static constexpr double kMaxCounts = 4e5;
  struct Key {
    std::uint64_t n, q;
    bool operator==(const Key& o) const { return n == o.n && q == o.q; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const { return std::hash<std::uint64_t>()(k.n * 0x9E3779B97F4A7C15ull ^ k.q); }
  };
  struct Entry {
    std::size_t uses;
    double table_after, window;
    std::unique_ptr<binomial::QuantileTable> table;
  };
  static std::uint64_t bits(double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
  }
  void clear() {
    tables_.clear();
    counts_ = 0;
  }
  std::unordered_map<Key, Entry, KeyHash> tables_;
  double counts_ = 0;  // the tables' windows, in counts
};

class Roulette final : public RowwiseRule<Roulette> {
 public:
  explicit Roulette(double eps) : eps_(eps) {}
  std::string name() const override { return "roulette"; }
  LawParams params() const override { return {{"epsilon", eps_}}; }
  // The upper level at w = 0 (P on a level's area) keeps none of its facets, whatever its count
  // (kept() of any k at weight 0 is 0): it is not drawn, as the other rules skip a level of weight 0.
  // The same K, bit for bit.
  std::array<double, 2> trials(double density, double, const LevelBracket& b) const override {
    return {density * b.area_lo, b.w_lod > 0 ? density * b.area_hi : 0.0};
  }
  bool thins() const override { return true; }
  bool has_pmf() const override { return eps_ == 0; }

  // The hard roulette's kept count from the stream's first two uniforms.
  static double hard_kept(double k, double weight, double u, double u_part) {
    const double whole = std::floor(k), part = k - whole;
    return blend_detail::thin(whole, weight, u) + (part > 0 && u_part < weight ? part : 0.0);
  }
  // hard_kept with thin's binomial quantiles from this thread's tables: the same bits.
  static double hard_kept_cached(double k, double weight, double u, double u_part) {
    const double whole = std::floor(k), part = k - whole;
    double kept;
    if (whole <= 0 || weight <= 0) {
      kept = 0.0;
    } else if (weight >= 1) {
      kept = whole;
    } else {
      thread_local ThinTables tables;
      kept = tables(whole, weight, u);
    }
    return kept + (part > 0 && u_part < weight ? part : 0.0);
  }
  // Above kExplicitFacets: the normal with the kept sum's exact moments, from one uniform.
  static double normal_kept(double k, const std::array<double, 2>& m, double u) {
    const double sd = std::sqrt(std::max(0.0, k * (m[1] - m[0] * m[0])));
    // sd = 0 (weight 0 or 1: every facet's R is 0 or 1): sd times the finite quantile of a uniform in
    // (0, 1) adds a signed zero, which leaves k m[0] unchanged, so the quantile is not computed.
    return std::clamp(sd > 0 ? k * m[0] + sd * normal::quantile(u) : k * m[0], 0.0, k);
  }

  double kept(double k, double weight, FacetStream& facets) const {
    if (k <= 0) return 0.0;
    if (eps_ == 0) {
      const double u = facets.uniform(), u_part = facets.uniform();
      return hard_kept(k, weight, u, u_part);
    }
    if (k <= kExplicitFacets) {
      const double whole = std::floor(k), part = k - whole;
      double sum = 0;
      for (double i = 0; i < whole; ++i) sum += blend_detail::roulette_keep(facets.uniform(), weight, eps_);
      if (part > 0) sum += part * blend_detail::roulette_keep(facets.uniform(), weight, eps_);
      return sum;
    }
    return normal_kept(k, blend_detail::roulette_moments(weight, eps_), facets.uniform());
  }

  // One bracket for all rows (the scales P / A_l once), and a bracket per row (P per sample): both
  // by rows(), the same operations as combine() per row, so the same bits.
  void combine_rows(double area, const LevelBracket& b, std::size_t m, const double* k_lo, const double* k_hi,
                    const FacetRows& facets, double* out) const override {
    const double scale[2] = {area / b.area_lo, area / b.area_hi};
    rows(
        m, true, [&](std::size_t) -> const LevelBracket& { return b; }, [&](std::size_t, int j) { return scale[j]; },
        k_lo, k_hi, facets, out);
  }
  void combine_rows_each(const double* area, const LevelBracket* b, std::size_t m, const double* k_lo,
                         const double* k_hi, const FacetRows& facets, double* out) const override {
    rows(
        m, false, [&](std::size_t r) -> const LevelBracket& { return b[r]; },
        [&](std::size_t r, int j) { return area[r] / (j == 0 ? b[r].area_lo : b[r].area_hi); }, k_lo, k_hi, facets,
        out);
  }

  double combine(double area, const LevelBracket& b, double k_lo, double k_hi,
                 std::array<FacetStream, 2>& facets) const override {
    return area / b.area_lo * kept(k_lo, 1.0 - b.w_lod, facets[0]) + area / b.area_hi * kept(k_hi, b.w_lod, facets[1]);
  }

  Distribution combine_pmf(double area, const LevelBracket& b, const Distribution& lo, const Distribution& hi,
                           std::size_t max_support) const override {
    if (eps_ > 0)
      throw not_implemented(
          "blended_law('roulette', epsilon > 0): the mollified roulette's K has a continuous "
          "part and no exact pmf; estimate one from samples instead");
    return scaled_sum(blend_detail::thinned(lo, 1.0 - b.w_lod, max_support), area / b.area_lo,
                      blend_detail::thinned(hi, b.w_lod, max_support), area / b.area_hi, true, max_support,
                      "blended_law('roulette').pmf");
  }

 private:
  // out[r] = scale(r, 0) kept_lo + scale(r, 1) kept_hi for rows r < m, bracket(r) the row's bracket. The hard roulette
  // and the explicit facets as kept() does; the normal sums (eps > 0, k > 64, first block given) by the vector kernel a
  // block of rows at a time, each row's moments and, where its quantile is central (85 % of rows), its kept sum; the
  // scalar normal_kept finishes the rows in the quantile's tails (it needs a logarithm) from the kernel's moments.
  template <class BracketOf, class ScaleOf>
  void rows(std::size_t m, bool one_bracket, BracketOf bracket, ScaleOf scale, const double* k_lo, const double* k_hi,
            const FacetRows& facets, double* out) const {
    const double* counts[2] = {k_lo, k_hi};
    constexpr std::size_t kBlock = 256;
    alignas(64) double batch[2][3][kBlock];  // per level: kept sum (NaN: scalar), E[R], E[R^2]
    alignas(64) double w_lod[kBlock];        // the rows' w_lod side by side, for the kernel
    std::uint32_t tail[2][kBlock + 16];      // the kernel's lists of tail rows
    alignas(64) double gathered[6][kBlock];  // a level's tail rows: k, E[R], E[R^2], u, log, kept
    const bool normal_kernel = eps_ > 0 && (facets.first[0] || facets.first[1]);
    for (std::size_t r0 = 0; r0 < m; r0 += kBlock) {
      const std::size_t n = std::min(kBlock, m - r0);
      if (normal_kernel) {
        detail::RouletteRows block;
        block.m = n;
        if (one_bracket) {
          block.w_lod = &bracket(0).w_lod;
          block.w_step = 0;
        } else {
          for (std::size_t i = 0; i < n; ++i) w_lod[i] = bracket(r0 + i).w_lod;
          block.w_lod = w_lod;
          block.w_step = 1;
        }
        block.eps = eps_;
        for (std::size_t j = 0; j < 2; ++j) {
          block.k[j] = counts[j] + r0;
          block.first[j] = facets.first[j] ? facets.first[j] + 2 * r0 : nullptr;
          block.level[j] = batch[j][0];
          block.mom0[j] = batch[j][1];
          block.mom1[j] = batch[j][2];
          block.tail[j] = tail[j];
        }
        detail::roulette_normal_rows(block);
        // The rows whose quantile is in a tail (NaN), as the kernel listed them: gathered, each with
        // quantile's own logarithm (std::log, the one scalar step: the bits), then normal_kept of
        // them all in a vector kernel, and scattered back (rows on other paths are computed and
        // not read). No branch per row.
        for (std::size_t j = 0; j < 2; ++j) {
          const std::size_t tails = block.tails[j];
          if (tails == 0) continue;
          const double* first = facets.first[j] + 2 * r0;
          for (std::size_t t = 0; t < tails; ++t) {
            const std::size_t i = tail[j][t];
            const double u = first[2 * i];
            gathered[0][t] = counts[j][r0 + i];
            gathered[1][t] = batch[j][1][i];
            gathered[2][t] = batch[j][2][i];
            gathered[3][t] = u;
            gathered[4][t] = std::log(u - 0.5 < 0.0 ? u : 1.0 - u);
          }
          detail::roulette_normal_kept(gathered[0], gathered[1], gathered[2], gathered[3], gathered[4], tails,
                                       gathered[5]);
          for (std::size_t t = 0; t < tails; ++t) batch[j][0][tail[j][t]] = gathered[5][t];
        }
        // The usual block: every level of every row either empty or a normal sum (as the row loop
        // below would decide): K straight from the batch, without the per-row branches.
        bool all_normal = !block.explicit_rows;
        for (std::size_t j = 0; j < 2 && all_normal; ++j)
          if (!facets.first[j]) {
            const double* k = counts[j] + r0;
            int other = 0;
            for (std::size_t i = 0; i < n; ++i) other |= !(k[i] <= 0);
            all_normal = other == 0;
          }
        if (all_normal) {
          const double* k0 = counts[0] + r0;
          const double* k1 = counts[1] + r0;
          const bool has[2] = {facets.first[0] != nullptr, facets.first[1] != nullptr};
          for (std::size_t i = 0; i < n; ++i) {
            const double lo = has[0] && !(k0[i] <= 0) ? batch[0][0][i] : 0.0;
            const double hi = has[1] && !(k1[i] <= 0) ? batch[1][0][i] : 0.0;
            out[r0 + i] = scale(r0 + i, 0) * lo + scale(r0 + i, 1) * hi;
          }
          continue;
        }
      }
      for (std::size_t i = 0; i < n; ++i) {
        const std::size_t r = r0 + i;
        const LevelBracket& b = bracket(r);
        double level[2];
        for (std::size_t j = 0; j < 2; ++j) {
          const double k = counts[j][r];
          const double* first = facets.first[j];
          const double weight = j == 0 ? 1.0 - b.w_lod : b.w_lod;
          if (k <= 0) {
            level[j] = 0.0;
          } else if (first && eps_ == 0) {
            // One weight for every row: its counts recur, so thin from this thread's tables. (A weight
            // per row, P per sample, would only fill them with pairs used once.)
            level[j] = one_bracket ? hard_kept_cached(k, weight, first[2 * r], first[2 * r + 1])
                                   : hard_kept(k, weight, first[2 * r], first[2 * r + 1]);
          } else if (first && k > kExplicitFacets) {
            level[j] = batch[j][0][i];
          } else {
            FacetStream stream = facets.stream(r, static_cast<int>(j));
            level[j] = kept(k, weight, stream);
          }
        }
        out[r] = scale(r, 0) * level[0] + scale(r, 1) * level[1];
      }
    }
  }

  double eps_;
};

const bool registered = register_blend(
    {"roulette",
     "KPT25 Russian roulette: each facet of a level kept with the level's weight (epsilon > 0: eq. 8 mollified)",
     [](const LawParams& params) -> std::unique_ptr<BlendRule> {
       ParamReader reader("roulette", params);
       const double eps = reader.number("epsilon", 0.1);
       reader.finish();
       if (!(eps >= 0.0 && eps <= 0.5))
         throw_invalid("blended_law('roulette')", "epsilon", eps, "a number in [0, 0.5] (0: hard roulette)");
       return std::make_unique<Roulette>(eps);
     }});

}  // namespace
}  // namespace glintlab
