// The exact binomial's vector kernels (binomial_simd_body.inc) for AVX2 (called only when the CPU has it).
#define GLINTLAB_BINOMIAL_ROWS_KERNEL glintlab::detail::binomial_btrd_rows_avx2
#define GLINTLAB_BINOMIAL_ATTEMPT_KERNEL glintlab::detail::binomial_btrd_attempt_avx2
#define GLINTLAB_BINOMIAL_PREPARE_KERNEL glintlab::detail::binomial_pixels_prepare_avx2
#define GLINTLAB_BINOMIAL_INVERSION_STEPS_KERNEL glintlab::detail::binomial_inversion_steps_avx2
#define GLINTLAB_BINOMIAL_PIXELS_ATTEMPT_KERNEL glintlab::detail::binomial_pixels_attempt_avx2
#define GLINTLAB_BINOMIAL_PIXELS_KERNEL glintlab::detail::binomial_pixels_avx2
#include "binomial_simd_body.inc"
