// Batch generation of the counter-based uniforms of fill_uniforms(): Philox4x32-10 for 32 rows at a
// time with AVX-512 or 8 with AVX2 (the 32x32 -> 64-bit multiplies of even and odd lanes),
// dispatched at run time, and a portable path for other CPUs. Both are bit-identical to CounterRng: the same
// Philox4x32-10 (Salmon et al. 2011, constants as in Random123), counter layout and 53-bit conversion;
// tests/cpp/test_rng.cpp checks the identity for both paths.
#include <immintrin.h>

// GCC 12's AVX-512 intrinsics start from an undefined vector and trip -Wmaybe-uninitialized.
#if defined(__GNUC__) && !defined(__clang__)  // a GCC-only warning (Clang has no such group)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <algorithm>
#include <atomic>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "glintlab/base/errors.hpp"
#include "glintlab/detail/uniform_rows.hpp"

namespace glintlab::detail {

namespace {

constexpr std::uint32_t kM0 = 0xD2511F53u, kM1 = 0xCD9E8D57u;  // Philox4x32 multipliers
constexpr std::uint32_t kW0 = 0x9E3779B9u, kW1 = 0xBB67AE85u;  // Weyl key increments

inline double to_unit(std::uint32_t hi, std::uint32_t lo) {
  const std::uint64_t bits = (static_cast<std::uint64_t>(hi) << 32) | lo;
  return (static_cast<double>(bits >> 11) + 0.5) * 0x1.0p-53;
}

// Writes the two doubles of block `b` into row `row` (the second only if the row has room).
inline void store_block(double* row, std::size_t b, std::size_t k, std::uint32_t o0, std::uint32_t o1, std::uint32_t o2,
                        std::uint32_t o3) {
  row[2 * b] = to_unit(o0, o1);
  if (2 * b + 1 < k) row[2 * b + 1] = to_unit(o2, o3);
}

void rows_portable(std::uint32_t key0, std::uint32_t key1, std::uint32_t c3_init, std::size_t start, std::size_t count,
                   std::size_t k, double* out) {
  const std::size_t blocks = (k + 1) / 2;
  for (std::size_t r = 0; r < count; ++r) {
    const std::uint64_t row = start + r;
    for (std::size_t b = 0; b < blocks; ++b) {
      std::uint32_t c0 = static_cast<std::uint32_t>(b), c1 = static_cast<std::uint32_t>(row),
                    c2 = static_cast<std::uint32_t>(row >> 32), c3 = c3_init, k0 = key0, k1 = key1;
      for (int round = 0; round < 10; ++round) {
        const std::uint64_t p0 = static_cast<std::uint64_t>(kM0) * c0;
        const std::uint64_t p1 = static_cast<std::uint64_t>(kM1) * c2;
        c0 = static_cast<std::uint32_t>(p1 >> 32) ^ c1 ^ k0;
        c1 = static_cast<std::uint32_t>(p1);
        c2 = static_cast<std::uint32_t>(p0 >> 32) ^ c3 ^ k1;
        c3 = static_cast<std::uint32_t>(p0);
        k0 += kW0;
        k1 += kW1;
      }
      store_block(out + r * k, b, k, c0, c1, c2, c3);
    }
  }
}

// (hi, lo) of m * x for the 8 unsigned 32-bit lanes of x.
__attribute__((target("avx2"))) inline void mulhilo8(__m256i m, __m256i x, __m256i& hi, __m256i& lo) {
  const __m256i even = _mm256_mul_epu32(x, m);                        // lanes 0, 2, 4, 6
  const __m256i odd = _mm256_mul_epu32(_mm256_srli_epi64(x, 32), m);  // lanes 1, 3, 5, 7
  lo = _mm256_blend_epi32(even, _mm256_slli_epi64(odd, 32), 0xAA);
  hi = _mm256_blend_epi32(_mm256_srli_epi64(even, 32), odd, 0xAA);
}

// to_unit() of lanes 4h .. 4h + 3 of (hi, lo), with the same IEEE operations: the 53-bit integer
// x = (hi:lo) >> 11 is assembled exactly as a * 2^32 + b (a < 2^21, b < 2^32, each converted
// exactly), then (x + 0.5) * 2^-53 rounds as the scalar code does.
__attribute__((target("avx2"))) inline __m256d to_unit4(__m256i hi, __m256i lo, int h) {
  const __m256i a = _mm256_srli_epi32(hi, 11);
  const __m256i b = _mm256_or_si256(_mm256_slli_epi32(hi, 21), _mm256_srli_epi32(lo, 11));
  const __m128i a4 = h == 0 ? _mm256_castsi256_si128(a) : _mm256_extracti128_si256(a, 1);
  const __m128i b4 = h == 0 ? _mm256_castsi256_si128(b) : _mm256_extracti128_si256(b, 1);
  const __m256d da = _mm256_cvtepi32_pd(a4);
  // b as unsigned: flip the sign bit, convert signed, add 2^31 back (all exact).
  const __m256d db =
      _mm256_add_pd(_mm256_cvtepi32_pd(_mm_xor_si128(b4, _mm_set1_epi32(INT32_MIN))), _mm256_set1_pd(2147483648.0));
  const __m256d x = _mm256_add_pd(_mm256_mul_pd(da, _mm256_set1_pd(4294967296.0)), db);
  return _mm256_mul_pd(_mm256_add_pd(x, _mm256_set1_pd(0.5)), _mm256_set1_pd(0x1.0p-53));
}

// Rows r .. r + 3 of a two-uniform batch: [u0[r], u1[r], u0[r+1], u1[r+1], ...].
__attribute__((target("avx2"))) inline void store_interleaved(double* out, __m256d u0, __m256d u1) {
  const __m256d lo = _mm256_unpacklo_pd(u0, u1), hi = _mm256_unpackhi_pd(u0, u1);
  _mm256_storeu_pd(out, _mm256_permute2f128_pd(lo, hi, 0x20));
  _mm256_storeu_pd(out + 4, _mm256_permute2f128_pd(lo, hi, 0x31));
}

__attribute__((target("avx2"))) void rows_avx2(std::uint32_t key0, std::uint32_t key1, std::uint32_t c3_init,
                                               std::size_t start, std::size_t count, std::size_t k, double* out) {
  const std::size_t blocks = (k + 1) / 2;
  const __m256i m0 = _mm256_set1_epi32(static_cast<int>(kM0)), m1 = _mm256_set1_epi32(static_cast<int>(kM1));
  // The key schedule (Weyl sequence) once per call.
  __m256i round_key0[10], round_key1[10];
  for (std::uint32_t round = 0, k0 = key0, k1 = key1; round < 10; ++round, k0 += kW0, k1 += kW1) {
    round_key0[round] = _mm256_set1_epi32(static_cast<int>(k0));
    round_key1[round] = _mm256_set1_epi32(static_cast<int>(k1));
  }
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  std::size_t base = 0;
  for (; base + 8 <= count; base += 8) {
    const std::uint64_t first = start + base;
    // Row numbers: low words first + lane; the high word is per lane too (a batch may cross 2^32).
    alignas(32) std::uint32_t lo_words[8], hi_words[8];
    __m256i row_lo, row_hi;
    if ((first & 0xFFFFFFFFu) <= 0xFFFFFFFFu - 7) {  // the 8 rows share their high word
      row_lo = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(static_cast<std::uint32_t>(first))), lane);
      row_hi = _mm256_set1_epi32(static_cast<int>(static_cast<std::uint32_t>(first >> 32)));
    } else {
      for (int l = 0; l < 8; ++l) {
        lo_words[l] = static_cast<std::uint32_t>(first + static_cast<std::uint64_t>(l));
        hi_words[l] = static_cast<std::uint32_t>((first + static_cast<std::uint64_t>(l)) >> 32);
      }
      row_lo = _mm256_load_si256(reinterpret_cast<const __m256i*>(lo_words));
      row_hi = _mm256_load_si256(reinterpret_cast<const __m256i*>(hi_words));
    }
    for (std::size_t b = 0; b < blocks; ++b) {
      __m256i c0 = _mm256_set1_epi32(static_cast<int>(b));
      __m256i c1 = row_lo, c2 = row_hi;
      __m256i c3 = _mm256_set1_epi32(static_cast<int>(c3_init));
      for (int round = 0; round < 10; ++round) {
        __m256i hi0, lo0, hi1, lo1;
        mulhilo8(m0, c0, hi0, lo0);
        mulhilo8(m1, c2, hi1, lo1);
        c0 = _mm256_xor_si256(_mm256_xor_si256(hi1, c1), round_key0[round]);
        c1 = lo1;
        c2 = _mm256_xor_si256(_mm256_xor_si256(hi0, c3), round_key1[round]);
        c3 = lo0;
      }
      if (k <= 2) {
        // Vector conversion and store of the common one- and two-uniform rows.
        double* row0 = out + base * k;
        const __m256d u0_lo = to_unit4(c0, c1, 0), u0_hi = to_unit4(c0, c1, 1);
        if (k == 1) {
          _mm256_storeu_pd(row0, u0_lo);
          _mm256_storeu_pd(row0 + 4, u0_hi);
        } else {
          const __m256d u1_lo = to_unit4(c2, c3, 0), u1_hi = to_unit4(c2, c3, 1);
          store_interleaved(row0, u0_lo, u1_lo);
          store_interleaved(row0 + 8, u0_hi, u1_hi);
        }
        continue;
      }
      alignas(32) std::uint32_t o0[8], o1[8], o2[8], o3[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(o0), c0);
      _mm256_store_si256(reinterpret_cast<__m256i*>(o1), c1);
      _mm256_store_si256(reinterpret_cast<__m256i*>(o2), c2);
      _mm256_store_si256(reinterpret_cast<__m256i*>(o3), c3);
      for (int l = 0; l < 8; ++l) store_block(out + (base + l) * k, b, k, o0[l], o1[l], o2[l], o3[l]);
    }
  }
  // Clean the upper halves of the ymm registers before any SSE code runs: GCC turns the call
  // below into a tail jump without its usual vzeroupper, and dirty upper halves made every later
  // legacy-SSE conversion (cvtsi2sd, ...) in the caller's loop several times slower (measured: a
  // table-lookup loop after this function, 6.2 -> 0.8 ns per element).
  _mm256_zeroupper();
  rows_portable(key0, key1, c3_init, start + base, count - base, k, out + base * k);
}

// The AVX-512 path: each row's Philox state in the low halves of 64-bit lanes, 8 rows per vector,
// kGroups independent vectors in flight so that the ten dependent rounds of one group (multiply
// latency) overlap with the others'. vpmuludq multiplies the low 32 bits of each 64-bit lane into
// the full 64-bit product, so a round is two multiplies, two shifts (the high words down) and two
// three-way xors per 8 rows: the upper halves of the lanes carry garbage that no multiply reads and
// that the output's assembly drops (the 32-bit-lane layout needed even/odd splits and blends, 8
// operations per 8 rows and round instead of 6).
#define GLINTLAB_AVX512 __attribute__((target("avx512f,avx512dq,avx512bw,avx512vl")))

// to_unit() of 8 rows from the word vectors (hi, lo) in the low halves of their 64-bit lanes: the
// 64-bit word hi:lo >> 11 (53 bits, converted exactly), then (x + 0.5) * 2^-53 as the scalar code.
GLINTLAB_AVX512 inline __m512d to_unit8(__m512i hi, __m512i lo) {
  const __m512i bits = _mm512_mask_blend_epi32(0x5555, _mm512_slli_epi64(hi, 32), lo);  // even dwords: lo
  const __m512d x = _mm512_cvtepu64_pd(_mm512_srli_epi64(bits, 11));
  return _mm512_mul_pd(_mm512_add_pd(x, _mm512_set1_pd(0.5)), _mm512_set1_pd(0x1.0p-53));
}

GLINTLAB_AVX512 void rows_avx512(std::uint32_t key0, std::uint32_t key1, std::uint32_t c3_init, std::size_t start,
                                 std::size_t count, std::size_t k, double* out) {
  constexpr int kGroups = 4, kLanes = 8;
  const std::size_t blocks = (k + 1) / 2;
  const __m512i m0 = _mm512_set1_epi64(kM0), m1 = _mm512_set1_epi64(kM1);
  __m512i round_key0[10], round_key1[10];
  for (std::uint32_t round = 0, k0 = key0, k1 = key1; round < 10; ++round, k0 += kW0, k1 += kW1) {
    round_key0[round] = _mm512_set1_epi64(k0);
    round_key1[round] = _mm512_set1_epi64(k1);
  }
  const __m512i lane = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7);
  const __m512i interleave_lo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i interleave_hi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  std::size_t base = 0;
  for (; base + kGroups * kLanes <= count; base += kGroups * kLanes) {
    // Row numbers as 64-bit lanes: the low word is c1, the high word (row >> 32) c2, per lane (a
    // batch may cross 2^32).
    __m512i row[kGroups];
    for (int g = 0; g < kGroups; ++g)
      row[g] = _mm512_add_epi64(_mm512_set1_epi64(static_cast<long long>(start + base + g * kLanes)), lane);
    for (std::size_t b = 0; b < blocks; ++b) {
      __m512i c0[kGroups], c1[kGroups], c2[kGroups], c3[kGroups];
      for (int g = 0; g < kGroups; ++g) {
        c0[g] = _mm512_set1_epi64(static_cast<long long>(b));
        c1[g] = row[g];
        c2[g] = _mm512_srli_epi64(row[g], 32);
        c3[g] = _mm512_set1_epi64(c3_init);
      }
      for (int round = 0; round < 10; ++round) {
        for (int g = 0; g < kGroups; ++g) {
          const __m512i p0 = _mm512_mul_epu32(c0[g], m0), p1 = _mm512_mul_epu32(c2[g], m1);
          c0[g] = _mm512_ternarylogic_epi64(_mm512_srli_epi64(p1, 32), c1[g], round_key0[round], 0x96);
          c1[g] = p1;
          c2[g] = _mm512_ternarylogic_epi64(_mm512_srli_epi64(p0, 32), c3[g], round_key1[round], 0x96);
          c3[g] = p0;
        }
      }
      for (int g = 0; g < kGroups; ++g) {
        const std::size_t r0 = base + static_cast<std::size_t>(g * kLanes);
        if (k <= 2) {
          double* dst = out + r0 * k;
          const __m512d a = to_unit8(c0[g], c1[g]);
          if (k == 1) {
            _mm512_storeu_pd(dst, a);
          } else {
            const __m512d bb = to_unit8(c2[g], c3[g]);
            _mm512_storeu_pd(dst, _mm512_permutex2var_pd(a, interleave_lo, bb));
            _mm512_storeu_pd(dst + 8, _mm512_permutex2var_pd(a, interleave_hi, bb));
          }
          continue;
        }
        alignas(64) std::uint64_t o0[kLanes], o1[kLanes], o2[kLanes], o3[kLanes];
        _mm512_store_si512(o0, c0[g]);
        _mm512_store_si512(o1, c1[g]);
        _mm512_store_si512(o2, c2[g]);
        _mm512_store_si512(o3, c3[g]);
        for (int l = 0; l < kLanes; ++l)
          store_block(out + (r0 + static_cast<std::size_t>(l)) * k, b, k, static_cast<std::uint32_t>(o0[l]),
                      static_cast<std::uint32_t>(o1[l]), static_cast<std::uint32_t>(o2[l]),
                      static_cast<std::uint32_t>(o3[l]));
      }
    }
  }
  _mm256_zeroupper();  // see rows_avx2
  rows_avx2(key0, key1, c3_init, start + base, count - base, k, out + base * k);
}

}  // namespace

namespace {
int cpu_simd_level() {
  static const int level = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                                   __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl")
                               ? 2
                               : (__builtin_cpu_supports("avx2") ? 1 : 0);
  return level;
}
std::atomic<int> simd_setting{2};
}  // namespace

void set_simd_level(int level) {
  if (level < 0 || level > 2)
    throw_invalid_message("set_simd_level: level = " + std::to_string(level) +
                          " is not 0 (portable), 1 (AVX2) or 2 (AVX-512)");
  simd_setting.store(level, std::memory_order_relaxed);
}

int simd_level() { return std::min(simd_setting.load(std::memory_order_relaxed), cpu_simd_level()); }

// Rows [start, start + count): row r gets blocks 0 .. ceil(k/2) - 1 of key (seed, r, stream).
void philox_uniform_rows(std::uint64_t seed, std::uint16_t stream, std::size_t start, std::size_t count, int k,
                         double* out) {
  const std::uint32_t key0 = static_cast<std::uint32_t>(seed), key1 = static_cast<std::uint32_t>(seed >> 32);
  const std::uint32_t c3 = stream;  // level 0 in the upper 16 bits
  const std::size_t kk = static_cast<std::size_t>(k);
  const int level = simd_level();
  if (level >= 2)
    rows_avx512(key0, key1, c3, start, count, kk, out);
  else if (level >= 1)
    rows_avx2(key0, key1, c3, start, count, kk, out);
  else
    rows_portable(key0, key1, c3, start, count, kk, out);
}

// The same rows keyed at LOD level `level` (the counter's upper 16 bits, as CounterRng's).
void philox_uniform_rows_level(std::uint64_t seed, std::uint16_t level, std::uint16_t stream, std::size_t start,
                               std::size_t count, int k, double* out) {
  const std::uint32_t key0 = static_cast<std::uint32_t>(seed), key1 = static_cast<std::uint32_t>(seed >> 32);
  const std::uint32_t c3 = (static_cast<std::uint32_t>(level) << 16) | stream;
  const std::size_t kk = static_cast<std::size_t>(k);
  const int simd = simd_level();
  if (simd >= 2)
    rows_avx512(key0, key1, c3, start, count, kk, out);
  else if (simd >= 1)
    rows_avx2(key0, key1, c3, start, count, kk, out);
  else
    rows_portable(key0, key1, c3, start, count, kk, out);
}

}  // namespace glintlab::detail
