// The gated law's per-pixel kernel for avx2 (see gated_pixels_body.inc); called only when the CPU has it.
#include "simd_math.hpp"

#define GLINTLAB_GATED_KERNEL glintlab::detail::gated_pixels_avx2
#include "gated_pixels_body.inc"
