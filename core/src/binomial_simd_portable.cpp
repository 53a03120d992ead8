// The exact binomial's vector kernels (binomial_simd_body.inc) for the baseline x86-64 instruction set (SSE2): the portable level.
#define GLINTLAB_BINOMIAL_ROWS_KERNEL glintlab::detail::binomial_btrd_rows_portable
#define GLINTLAB_BINOMIAL_ATTEMPT_KERNEL glintlab::detail::binomial_btrd_attempt_portable
#define GLINTLAB_BINOMIAL_PREPARE_KERNEL glintlab::detail::binomial_pixels_prepare_portable
#define GLINTLAB_BINOMIAL_INVERSION_STEPS_KERNEL glintlab::detail::binomial_inversion_steps_portable
#define GLINTLAB_BINOMIAL_PIXELS_KERNEL glintlab::detail::binomial_pixels_portable
#include "binomial_simd_body.inc"
