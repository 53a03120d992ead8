// Private helpers of KPT25's glinty NDF, shared by its source files (glinty_ndf.cpp: the maps, the pixel
// set-up, Algorithm 1 and the reference; kpt25_disk.cpp: the disk integrals; kpt25_sampling.cpp:
// Algorithm 2; kpt25_triplanar.cpp: the UV-free glints; kpt25_lights.cpp: the points under a light). One
// enumeration of the point process (for_each_point) and one roulette weight per point (point_keep) serve
// every caller, so the evaluation, the reference, the sampler, its pdf, the visible counts and the counts
// under a light see the same points by construction.
// docs/math/glinty_ndf.md.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"

namespace glintlab::kpt25 {

inline constexpr char kWhere[] = "glinty_ndf kpt25";
inline constexpr double kPi = std::numbers::pi;
inline constexpr double kSqrt1_2 = 0.70710678118654752440;
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The spatial filter is a Gaussian truncated at Mahalanobis radius 3 and renormalised, so that the
// explicit sum and the reference enumerate the same finite set of cells and the filter still integrates
// to 1 (docs/math/glinty_ndf.md#glinty-filter). 1 - exp(-9/2) is the mass a 2D Gaussian keeps there.
inline constexpr double kFilterRadius = 3.0;
inline const double kFilterMass = -std::expm1(-0.5 * kFilterRadius * kFilterRadius);
// The largest filter weight a point can have, q_max = 1 / (pi filter^2), for the counts that take a point's
// weight as its keep rate (light counts, visible glints): the filter must be wide enough that q_max stays
// within the truncated filter's radius^2. `use` names the count in the error.
inline double point_filter_limit(double filter, const char* use) {
  const double q_max = 1.0 / (kPi * filter * filter);
  if (!(q_max <= kFilterRadius * kFilterRadius))
    throw_invalid(kWhere, "filter", filter, std::string("a filter std >= 1 / (3 sqrt(pi)) for ") + use);
  return q_max;
}
// Angular cells farther than this many stds from T(h) contribute exp(-x^2/2) = 0 in double arithmetic
// (exp underflows to 0 below -745.2, and 39^2/2 = 760.5): skipping them keeps the reference an exact sum.
inline constexpr double kUnderflowRadius = kGlintUnderflowRadius;
// Random numbers of the points: a stream id of their own in the top byte of the last counter word, so
// they share nothing with the other users of a seed (rng.hpp keeps stream ids below 256 in the low
// 16 bits with the level above, a word below 2^24 for every level in use).
inline constexpr std::uint32_t kStreamGlintPoints = 8;
// The draws of Algorithm 2: their own stream id and key (draw_seed), so they share nothing with the
// points' numbers (stream 8 in the top byte of the last counter word) or the other users of a seed.
inline constexpr std::uint16_t kStreamGlintDraw = 9;

// Phi(b) - Phi(a) for a <= b without cancellation in either tail.
inline double normal_mass(double a, double b) {
  if (!(b > a)) return 0.0;
  // Shortcuts that return what the formulas below round to (Algorithm 2 asks for many masses of
  // narrow lobes, most of them 0 or 1): erfc(40 / sqrt 2) underflows to 0, and the tails beyond
  // 8.5 stds add up to less than half an ulp of 1.
  if (a > 40.0 || b < -40.0) return 0.0;
  if (a < -8.5 && b > 8.5) return 1.0;
  if (a >= 0.0) return 0.5 * (std::erfc(a * kSqrt1_2) - std::erfc(b * kSqrt1_2));
  if (b <= 0.0) return 0.5 * (std::erfc(-b * kSqrt1_2) - std::erfc(-a * kSqrt1_2));
  return 1.0 - 0.5 * (std::erfc(-a * kSqrt1_2) + std::erfc(b * kSqrt1_2));
}

// Mass of N(c, sigma^2) in [lo, hi].
inline double mass_1d(double c, double sigma, double lo, double hi) {
  return normal_mass((lo - c) / sigma, (hi - c) / sigma);
}

// Spatial cells are keyed by their full indices: positions must lie within this many cells (of level 0)
// of the origin, where the indices' bits above 32 fit point_block's counter (docs/math/glinty_ndf.md#glinty-process).
inline constexpr double kMaxCellIndex = 274877906944.0;  // 2^38

// The bits of a spatial cell index above its low 32, offset by 2^31 (cells in [-2^31, 2^31) give 0: the
// counters of the 32-bit layout before issue 37) and masked to 8 bits: distinct within 2^38 cells.
inline std::uint32_t cell_high_bits(std::int64_t i) {
  return static_cast<std::uint32_t>((i + (std::int64_t{1} << 31)) >> 32) & 0xffu;
}

// One Philox block of a point: counter (2 a + block | hi(i) << 16 | hi(j) << 24, i, j, stream << 24 |
// level << 20 | tag << 16 | b), key = seed; hi() the index bits above 32 (cell_high_bits). a, b < 2^15 and
// level <= 15 fit (kGlintMaxLevel); tag < 4 selects the point process of a triplanar plane (0: the
// uv-mapped process, and every plane when they share one).
inline std::array<std::uint32_t, 4> point_block(std::uint64_t seed, int level, std::int64_t i, std::int64_t j,
                                                std::int64_t a, std::int64_t b, std::uint32_t block,
                                                std::uint32_t tag = 0) {
  const std::array<std::uint32_t, 4> counter = {
      (static_cast<std::uint32_t>(2 * a) + block) | (cell_high_bits(i) << 16) | (cell_high_bits(j) << 24),
      static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j),
      (kStreamGlintPoints << 24) | (static_cast<std::uint32_t>(level) << 20) | (tag << 16) |
          static_cast<std::uint32_t>(b)};
  return CounterRng::block(counter, {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)});
}

// 32 random bits to a uniform in (0, 1).
inline double unit(std::uint32_t w) { return (static_cast<double>(w) + 0.5) * 0x1.0p-32; }

// The cells [first, last] of one axis of B(k): the side x side block of cells whose centres are nearest
// to q (in cells), shifted to stay inside [0, n); the whole axis when n < side.
inline void block_range(double q, std::int64_t n, int side, std::int64_t& first, std::int64_t& last) {
  if (n <= side) {
    first = 0;
    last = n - 1;
    return;
  }
  first = static_cast<std::int64_t>(std::floor(q - 0.5 * (side - 1)));
  first = std::clamp<std::int64_t>(first, 0, n - side);
  last = first + side - 1;
}

// A rectangle of angular cells of one level: [a0, a1] x [b0, b1].
struct CellRange {
  std::int64_t a0 = 0, a1 = -1, b0 = 0, b1 = -1;
};

// B(k) of the point (x, y) of the unit square at `level` (Algorithm 1; Algorithm 2 for x_a).
inline CellRange block_cells(double x, double y, int level, int k) {
  const std::int64_t na = std::int64_t{1} << level;
  const double fna = static_cast<double>(na);
  const int side = static_cast<int>(std::lround(std::sqrt(k)));
  CellRange c;
  block_range(x * fna, na, side, c.a0, c.a1);
  block_range(y * fna, na, side, c.b0, c.b1);
  return c;
}

// The angular cells within rx of x and ry of y (the reference's reach, the visible glints' disk).
inline CellRange window_cells(double x, double y, double rx, double ry, int level) {
  const std::int64_t na = std::int64_t{1} << level;
  const double fna = static_cast<double>(na);
  CellRange c;
  c.a0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((x - rx) * fna)));
  c.a1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((x + rx) * fna)));
  c.b0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((y - ry) * fna)));
  c.b1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((y + ry) * fna)));
  return c;
}

// The spatial cells [i0, i1] x [j0, j1] of `level` that the filter's box around (u, v) touches.
struct SpatialRange {
  double cell = 0.0;  // the cell side at this level, in units of x_s
  std::int64_t i0 = 0, i1 = -1, j0 = 0, j1 = -1;
};

inline SpatialRange spatial_cells(double res, const GlintPixel& px, int level, double u, double v) {
  SpatialRange s;
  s.cell = std::ldexp(1.0, level) / res;
  s.i0 = static_cast<std::int64_t>(std::floor((u - px.half_u) / s.cell));
  s.i1 = static_cast<std::int64_t>(std::floor((u + px.half_u) / s.cell));
  s.j0 = static_cast<std::int64_t>(std::floor((v - px.half_v) / s.cell));
  s.j1 = static_cast<std::int64_t>(std::floor((v + px.half_v) / s.cell));
  return s;
}

// The one enumeration of the point process (§3.3.1-3.3.2): every point of level `level` in the angular
// cells `cells` whose normal lies in the disk U and whose position falls in the pixel's truncated filter
// around (u, v) (x_s coordinates), in the order i, j, a, b: f(i, j, a, b, mx, my, q) with (mx, my) its
// normal in the unit square and q its Mahalanobis distance squared in the filter. `tag` selects a
// triplanar plane's process.
template <class F>
void for_each_point(double res, const GlintPixel& px, int level, double u, double v, std::uint64_t seed,
                    std::uint32_t tag, const CellRange& cells, F&& f) {
  const SpatialRange s = spatial_cells(res, px, level, u, v);
  const double inv_na = std::ldexp(1.0, -level);
  for (std::int64_t i = s.i0; i <= s.i1; ++i)
    for (std::int64_t j = s.j0; j <= s.j1; ++j)
      for (std::int64_t a = cells.a0; a <= cells.a1; ++a)
        for (std::int64_t b = cells.b0; b <= cells.b1; ++b) {
          const auto r4 = point_block(seed, level, i, j, a, b, 0, tag);
          // Normal-space coordinates in the unit square; points outside the disk U are rejected (§3.3.1).
          const double mx = (static_cast<double>(a) + unit(r4[2])) * inv_na;
          const double my = (static_cast<double>(b) + unit(r4[3])) * inv_na;
          if ((mx - 0.5) * (mx - 0.5) + (my - 0.5) * (my - 0.5) >= 0.25) continue;
          const double dx = (static_cast<double>(i) + unit(r4[0])) * s.cell - u;
          const double dy = (static_cast<double>(j) + unit(r4[1])) * s.cell - v;
          const double q = px.inv_a * dx * dx + 2.0 * px.inv_b * dx * dy + px.inv_c * dy * dy;
          if (q > kFilterRadius * kFilterRadius) continue;
          f(i, j, a, b, mx, my, q);
        }
}

// The blend weight of one point: its level's roulette R(r, w_l) of eq. 8 (w_l itself with the linear
// blend, or a level of weight 1) times, for a triplanar plane of weight w_i < 1, a second roulette
// R(r', w_i) on a random number of the point's own (the third word of its roulette block), independent
// of the level's, so that the keep rates multiply (w_i itself with the linear blend).
inline double point_keep(const Kpt25Params& p, std::uint64_t seed, int level, std::int64_t i, std::int64_t j,
                         std::int64_t a, std::int64_t b, double weight, double plane_weight = 1.0,
                         std::uint32_t tag = 0) {
  const bool roulette = p.blend == GlintBlend::roulette && weight < 1.0;
  const bool plane_roulette = plane_weight < 1.0 && p.blend == GlintBlend::roulette;
  double keep = weight;
  if (roulette || plane_roulette) {
    const auto r1 = point_block(seed, level, i, j, a, b, 1, tag);
    if (roulette) keep = kpt25_roulette(unit(r1[0]), weight, p.epsilon);
    if (plane_roulette) keep *= kpt25_roulette(unit(r1[2]), plane_weight, p.epsilon);
  } else if (plane_weight < 1.0) {
    keep *= plane_weight;
  }
  return keep;
}

// "uv[3, 0]": pixel i (of the flattened pixels), component c; the Python layer rewrites the pixel index
// as the multi-index of the caller's array.
inline std::string element(const char* name, std::size_t i, int c) {
  return std::string(name) + "[" + std::to_string(i) + ", " + std::to_string(c) + "]";
}
inline std::string row_name(const char* name, std::size_t i) {
  return std::string(name) + "[" + std::to_string(i) + ", :]";
}
// Ten significant digits: enough to recognise the caller's numbers (3.16, not 3.1600000000000001).
inline std::string short_value(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return buf;
}
inline std::string row_value(const double* x, int n) {
  std::string s = "[";
  for (int c = 0; c < n; ++c) s += (c ? ", " : "") + short_value(x[c]);
  return s + "]";
}

// A finite position whose cells (cells_per_unit of level 0 per unit) lie within kMaxCellIndex of the
// origin, and |x| <= 1e9; name[i, c] in the message.
void check_position(const char* name, const double* x, std::size_t i, int n, double cells_per_unit);

// A unit vector from any nonzero finite vector: scaled by its largest component first, so that neither
// 1e160 (whose squared length overflows) nor 1e-160 (whose squared length underflows) changes the
// result (docs/math/glinty_ndf.md#glinty-map). False for a zero vector.
inline bool unit_vector(const double* v, double out[3]) {
  const double s = std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
  if (!(s > 0.0)) return false;
  const double x = v[0] / s, y = v[1] / s, z = v[2] / s;
  const double len = std::sqrt(x * x + y * y + z * z);  // in [1, sqrt 3]
  out[0] = x / len;
  out[1] = y / len;
  out[2] = z / len;
  return true;
}

}  // namespace glintlab::kpt25
