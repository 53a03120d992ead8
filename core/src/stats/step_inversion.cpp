#include "glintlab/stats/step_inversion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <immintrin.h>

#include "glintlab/detail/uniform_rows.hpp"
#include "glintlab/stats/normal.hpp"

// GCC 12's AVX-512 intrinsics start from an undefined vector and trip -Wmaybe-uninitialized.
#if defined(__GNUC__) && !defined(__clang__)  // a GCC-only warning (Clang has no such group)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace glintlab {

StepInversion::StepInversion(std::vector<double> thresholds, std::vector<double> guards, double base, bool exact_below,
                             bool exact_above)
    : t_(std::move(thresholds)), guard_(std::move(guards)), base_(base), exact_below_(exact_below),
      exact_above_(exact_above) {
  if (t_.size() != guard_.size()) throw std::logic_error("StepInversion: one guard per threshold");
  if (!std::is_sorted(t_.begin(), t_.end())) throw std::logic_error("StepInversion: unsorted thresholds");
  if (t_.size() > (1u << 24)) throw std::logic_error("StepInversion: too many thresholds");
  // At least 64 cells per threshold (so few cells are void: a band touches one or two), within
  // 1 MiB of int32 so the table stays in a core's L2 cache.
  std::size_t size = 4096;
  while (size < 64 * t_.size() && size < (std::size_t{1} << 18)) size *= 2;
  cells_scale_ = static_cast<double>(size);
  cell_.assign(size, 0);
  // Count thresholds at or below each cell's left edge; then void the cells a band touches.
  std::size_t i = 0;
  for (std::size_t g = 0; g < size; ++g) {
    const double left = static_cast<double>(g) / cells_scale_;
    while (i < t_.size() && t_[i] <= left) ++i;
    cell_[g] = static_cast<std::int32_t>(i);
    if ((i == 0 && !exact_below_) || (i == t_.size() && !exact_above_)) cell_[g] = -1 - cell_[g];
  }
  for (std::size_t j = 0; j < t_.size(); ++j) {
    const double lo = std::max(0.0, t_[j] - guard_[j]) * cells_scale_;
    const double hi = std::min(1.0, t_[j] + guard_[j]) * cells_scale_;
    const std::size_t a = static_cast<std::size_t>(std::floor(lo));
    const std::size_t b = std::min(size - 1, static_cast<std::size_t>(std::floor(hi)));
    for (std::size_t g = a; g <= b && g < size; ++g)
      if (cell_[g] >= 0) cell_[g] = -1 - cell_[g];
  }
  cells_ = size;
  // Large tables in 16 bits (counts and -1 - counts fit below 2^15 - 1 thresholds): at (1e6, 0.3)
  // the gathers then hit L2, 2.25 -> 2.1 ns a gated sample; small ones stay in 32 bits, which
  // spare the vector path the sign extension (0.08 ns a sample).
  if (size >= (std::size_t{1} << 17) && t_.size() < 32767) {
    cell16_.assign(size + 1, 0);
    for (std::size_t g = 0; g < size; ++g) cell16_[g] = static_cast<std::int16_t>(cell_[g]);
    std::vector<std::int32_t>().swap(cell_);
  }
  // A void cell keeps its count as -1 - count: where search() starts.
  // A threshold on a cell's left edge belongs to that cell (t <= left counts it; the band covers
  // the cell to the left through floor(lo)), so every kept cell has one value throughout.
}

namespace {

#define GLINTLAB_AVX512 __attribute__((target("avx512f,avx512dq,avx512bw,avx512vl")))

// 8 doubles of column `col` of the 8 rows at u (row length k).
GLINTLAB_AVX512 inline __m512d load_column(const double* u, std::size_t k, std::size_t col) {
  if (k == 1) return _mm512_loadu_pd(u);
  if (k == 2) {
    const __m512i pick =
        col == 0 ? _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14) : _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
    return _mm512_permutex2var_pd(_mm512_loadu_pd(u), pick, _mm512_loadu_pd(u + 8));
  }
  const __m256i idx =
      _mm256_mullo_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32(static_cast<int>(k)));
  return _mm512_i32gather_pd(idx, u + col, 8);
}

// Rows [0, 8 * floor(rows / 8)) of affine_rows: the cells gathered, then the affine map, extra
// term and gate with the scalar code's operations (int32 -> double is exact; s * v is exact for
// s = +-1; a masked add of 1.0 where the scalar code adds 1.0, the value kept where it adds 0.0).
// mask[r / 8] gets the lanes whose cell is void. Returns the rows done.
GLINTLAB_AVX512 std::size_t affine_avx512(const std::int32_t* cells, const std::int16_t* cells16, std::size_t size,
                                          double scale, double base, const double* u, std::size_t k, std::size_t col,
                                          std::size_t rows, const StepInversion::Affine& f, double* out,
                                          std::uint8_t* mask) {
  const __m512d vscale = _mm512_set1_pd(scale), vbase = _mm512_set1_pd(base);
  const __m512d va = _mm512_set1_pd(f.a), vs = _mm512_set1_pd(f.s), one = _mm512_set1_pd(1.0);
  const __m512d gate_below = _mm512_set1_pd(f.gate_below), extra_below = _mm512_set1_pd(f.extra_below);
  const __m256i last = _mm256_set1_epi32(static_cast<int>(size - 1));
  std::size_t r = 0;
  for (; r + 8 <= rows; r += 8) {
    const double* row = u + r * k;
    __m256i cell = _mm512_cvttpd_epi32(_mm512_mul_pd(load_column(row, k, col), vscale));
    cell = _mm256_min_epi32(cell, last);  // u = 1 (probability 2^-53) lands in the last cell
    __m256i v;
    if (cells16 != nullptr) {  // 32 bits at each 16-bit cell's address, the cell in the low half
      v = _mm256_i32gather_epi32(reinterpret_cast<const int*>(cells16), cell, 2);
      v = _mm256_srai_epi32(_mm256_slli_epi32(v, 16), 16);
    } else {
      v = _mm256_i32gather_epi32(cells, cell, 4);
    }
    const __m512d step = _mm512_add_pd(_mm512_cvtepi32_pd(v), vbase);
    __m512d x = _mm512_add_pd(va, _mm512_mul_pd(vs, step));
    if (f.extra_col >= 0) {
      const __m512d ue = load_column(row, k, static_cast<std::size_t>(f.extra_col));
      x = _mm512_mask_add_pd(x, _mm512_cmp_pd_mask(ue, extra_below, _CMP_LT_OQ), x, one);
    }
    if (f.gate_col >= 0) {
      const __m512d ug = load_column(row, k, static_cast<std::size_t>(f.gate_col));
      x = _mm512_maskz_mov_pd(_mm512_cmp_pd_mask(ug, gate_below, _CMP_LT_OQ), x);
    }
    _mm512_storeu_pd(out + r, x);
    mask[r / 8] = static_cast<std::uint8_t>(_mm256_movepi32_mask(v));
  }
  _mm256_zeroupper();
  return r;
}

}  // namespace

void StepInversion::affine_rows(const double* u, std::size_t k, std::size_t col, std::size_t rows, const Affine& f,
                                double* out, std::uint8_t* mask) const {
  if (rows > 256) throw std::logic_error("StepInversion::affine_rows: at most 256 rows");
  // The scalar expression for row r from its step value v; false when v asks for direct evaluation.
  const auto finish = [&](std::size_t r, double v) {
    if (v < 0) return false;
    const double* row = u + r * k;
    double x = f.a + f.s * v;
    if (f.extra_col >= 0) x = x + (row[f.extra_col] < f.extra_below ? 1.0 : 0.0);
    out[r] = f.gate_col < 0 || row[f.gate_col] < f.gate_below ? x : 0.0;
    return true;
  };
  std::size_t done = 0;
  if (detail::simd_level() >= 2)
    done = affine_avx512(cell16_.empty() ? cell_.data() : nullptr, cell16_.empty() ? nullptr : cell16_.data(), cells_,
                         cells_scale_, base_, u, k, col, rows, f, out, mask);
  // Vector lanes on a void cell: the search of operator().
  for (std::size_t g = 0; g < done / 8; ++g)
    for (std::size_t l = 0; l < 8 && mask[g]; ++l)
      if ((mask[g] >> l & 1) && finish(8 * g + l, search(u[(8 * g + l) * k + col])))
        mask[g] = static_cast<std::uint8_t>(mask[g] & ~(1u << l));
  for (std::size_t g = done / 8; g < (rows + 7) / 8; ++g) mask[g] = 0;
  for (std::size_t r = done; r < rows; ++r)
    if (!finish(r, (*this)(u[r * k + col]))) mask[r / 8] = static_cast<std::uint8_t>(mask[r / 8] | 1u << (r % 8));
}

double StepInversion::search(double u) const {
  // A void cell stores -1 - #{t <= its left edge}: #{t <= u} is found by scanning the few
  // thresholds inside the cell (64 cells per mean gap between thresholds; at least 4 in any table).
  const std::size_t count = t_.size();
  std::size_t g = static_cast<std::size_t>(u * cells_scale_);
  if (g >= cells_) g = cells_ - 1;
  std::size_t i = static_cast<std::size_t>(-1 - static_cast<std::int64_t>(cell(g)));
  while (i < count && t_[i] <= u) ++i;
  if (i > 0 ? (u - t_[i - 1] < guard_[i - 1]) : !exact_below_) return -1.0;
  if (i < count ? (t_[i] - u <= guard_[i]) : !exact_above_) return -1.0;
  return base_ + static_cast<double>(i);
}

double StepInversion::gaussian_guard(double t, double z, double s, double slope, double magnitude) {
  constexpr double kEps = 2.220446049250313e-16;
  const double density = std::exp(-0.5 * z * z) * 0.3989422804014327;
  // Error of v in units of v, turned into an error of z (divide by s h'), then of u (times phi).
  const double dz = 8 * kEps * (magnitude + 1) / (s * slope) + 1e-15 * (std::abs(z) + 1);
  const double dt = 64 * kEps + 1e-14 * std::min(t, 1 - t);  // Phi at t, near 0 and near 1
  return 1e3 * (density * dz + dt);
}

std::optional<StepInversion> floor_gaussian_steps(double mean, double sd, double shift, double top,
                                                  std::size_t max_steps) {
  if (!(sd > 0) || !(top >= 0)) return std::nullopt;
  // Beyond 8.5 sd the law continues with probability < 1e-16: left to direct evaluation.
  const double lo = std::clamp(std::floor(mean + shift - 8.5 * sd), 0.0, top);
  const double hi = std::clamp(std::ceil(mean + shift + 8.5 * sd), 0.0, top);
  if (hi - lo > static_cast<double>(max_steps)) return std::nullopt;
  // Beyond 2^53 the steps j += 1 below would not advance (lo and hi may even round to one double):
  // no table there; the law evaluates directly.
  if (hi >= 0x1p53) return std::nullopt;
  const double magnitude = std::abs(mean) + std::abs(shift) + 9 * sd;
  std::vector<double> t, guard;
  double covered = 0;
  for (double j = lo + 1; j <= hi; j += 1) {  // v >= j  iff  z >= (j - shift - mean) / sd
    const double z = (j - shift - mean) / sd;
    t.push_back(normal::cdf(z));
    guard.push_back(StepInversion::gaussian_guard(t.back(), z, sd, 1.0, magnitude));
    covered += 2 * guard.back();
  }
  if (covered > 1e-3) return std::nullopt;
  return StepInversion(std::move(t), std::move(guard), lo, lo == 0, hi == top);
}

}  // namespace glintlab
