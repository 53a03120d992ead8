// The per-pixel kernels of gated and head_cf for avx2 (gated_pixels_body.inc, head_cf_pixels_body.inc);
// called only when the CPU has it.
#include "simd_math.hpp"

#define GLINTLAB_GATED_KERNEL glintlab::detail::gated_pixels_avx2
#include "gated_pixels_body.inc"

#define GLINTLAB_POLY7(c, x) \
  ((((((((c)[7] * (x) + (c)[6]) * (x) + (c)[5]) * (x) + (c)[4]) * (x) + (c)[3]) * (x) + (c)[2]) * (x) + (c)[1]) * (x) + (c)[0])
#define GLINTLAB_HEAD_CF_KERNEL glintlab::detail::head_cf_pixels_avx2
#include "head_cf_pixels_body.inc"
#undef GLINTLAB_POLY7
