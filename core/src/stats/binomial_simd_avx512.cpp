// The exact binomial's vector kernels (binomial_simd_body.inc) for AVX-512 (called only when the CPU has it).
#define GLINTLAB_BINOMIAL_ROWS_KERNEL glintlab::detail::binomial_btrd_rows_avx512
#define GLINTLAB_BINOMIAL_ATTEMPT_KERNEL glintlab::detail::binomial_btrd_attempt_avx512
#define GLINTLAB_BINOMIAL_PREPARE_KERNEL glintlab::detail::binomial_pixels_prepare_avx512
#define GLINTLAB_BINOMIAL_INVERSION_STEPS_KERNEL glintlab::detail::binomial_inversion_steps_avx512
#define GLINTLAB_BINOMIAL_PIXELS_ATTEMPT_KERNEL glintlab::detail::binomial_pixels_attempt_avx512
#define GLINTLAB_BINOMIAL_PIXELS_KERNEL glintlab::detail::binomial_pixels_avx512
#include "binomial_simd_body.inc"

#include <immintrin.h>

// GCC 12's AVX-512 intrinsics start from an undefined vector and trip -Wmaybe-uninitialized.
#if defined(__GNUC__) && !defined(__clang__)  // a GCC-only warning (Clang has no such group)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

std::size_t glintlab::detail::binomial_compact_avx512(const double* redo, const double* u, std::size_t rows,
                                                      std::uint32_t* row_of, double* v, double* u1) {
  // Eight rows per step: de-interleave (v, u1), compress the flagged lanes in registers (a compress
  // straight to memory is microcoded and slow on some CPUs) and store whole vectors.
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  std::size_t count = 0, i = 0;
  for (; i + 8 <= rows; i += 8) {
    const __mmask8 take = _mm512_cmpneq_pd_mask(_mm512_loadu_pd(redo + i), _mm512_setzero_pd());
    const __m512d a = _mm512_loadu_pd(u + 2 * i), b = _mm512_loadu_pd(u + 2 * i + 8);
    _mm512_storeu_pd(v + count, _mm512_maskz_compress_pd(take, _mm512_permutex2var_pd(a, even, b)));
    _mm512_storeu_pd(u1 + count, _mm512_maskz_compress_pd(take, _mm512_permutex2var_pd(a, odd, b)));
    const __m256i rows_here = _mm256_add_epi32(lane, _mm256_set1_epi32(static_cast<int>(i)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(row_of + count), _mm256_maskz_compress_epi32(take, rows_here));
    count += static_cast<std::size_t>(__builtin_popcount(take));
  }
  _mm256_zeroupper();
  for (; i < rows; ++i) {
    row_of[count] = static_cast<std::uint32_t>(i);
    v[count] = u[2 * i];
    u1[count] = u[2 * i + 1];
    count += redo[i] != 0.0;
  }
  return count;
}
