// The exact binomial's vector kernels (binomial_simd_body.inc) for AVX-512 (called only when the CPU has it).
#define GLINTLAB_BINOMIAL_ROWS_KERNEL glintlab::detail::binomial_btrd_rows_avx512
#define GLINTLAB_BINOMIAL_ATTEMPT_KERNEL glintlab::detail::binomial_btrd_attempt_avx512
#define GLINTLAB_BINOMIAL_PIXELS_KERNEL glintlab::detail::binomial_pixels_avx512
#include "binomial_simd_body.inc"
