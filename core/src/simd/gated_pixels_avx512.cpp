// The per-pixel kernels of gated and head_cf for avx512 (gated_pixels_body.inc, head_cf_pixels_body.inc);
// called only when the CPU has it.
#include "simd_math.hpp"

// GCC 12 sees the block functions' scratch arrays passed to the SLEEF loops, which read only the
// elements written just before, and warns that they may be uninitialized.
#if defined(__GNUC__) && !defined(__clang__)  // a GCC-only warning (Clang has no such group)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#define GLINTLAB_VEC_MATH glintlab::detail::vec_math_avx512
#define GLINTLAB_GATED_BLOCK glintlab::detail::gated_pixels_block_avx512
#include "gated_pixels_body.inc"

#define GLINTLAB_POLY7(c, x)                                                                                      \
  ((((((((c)[7] * (x) + (c)[6]) * (x) + (c)[5]) * (x) + (c)[4]) * (x) + (c)[3]) * (x) + (c)[2]) * (x) + (c)[1]) * \
       (x) +                                                                                                      \
   (c)[0])
#define GLINTLAB_HEAD_CF_KERNEL glintlab::detail::head_cf_pixels_avx512
#define GLINTLAB_HEAD_CF_BLOCK glintlab::detail::head_cf_pixels_block_avx512
#include "head_cf_pixels_body.inc"
#undef GLINTLAB_POLY7
