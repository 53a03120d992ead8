// The gated law's per-pixel kernel for avx512 (see gated_pixels_body.inc); called only when the CPU has it.
#include "simd_math.hpp"

#define GLINTLAB_GATED_KERNEL glintlab::detail::gated_pixels_avx512
#include "gated_pixels_body.inc"
