// Private helper of the core: the driver of the per-ISA per-pixel block functions of simd_math.hpp,
// for the laws' evaluate_pixels (gated.cpp, head_cf.cpp). Kept out of simd_math.hpp, which the
// ISA-compiled files include: an inline function there could be compiled with AVX-512 in one of
// them and picked by the linker for every caller.
#pragma once

#include <algorithm>
#include <cstddef>

#include "glintlab/detail/uniform_rows.hpp"  // detail::simd_level
#include "simd_math.hpp"

namespace glintlab::detail {
// A law's per-pixel block functions (gated_pixels_block_*, head_cf_pixels_block_*): a block of at
// most 256 pixels with two uniforms each; true when some redo[i] != 0.
using PixelBlock = bool (*)(const double* n, const double* p, const double* u, std::size_t m, double* out,
                            double* redo);

// Runs `count` pixels through the block function of the CPU's ISA, 256 at a time, and recomputes the
// flagged ones with eval(n, p, u_row). False (nothing done) when the CPU has neither AVX-512 nor
// AVX2 with FMA3 (SLEEF's AVX2 functions need it): the caller's scalar path runs instead.
template <class Eval>
bool run_pixel_blocks(PixelBlock avx512, PixelBlock avx2, const double* n, const double* p, const double* u,
                      std::size_t count, double* out, Eval&& eval) {
  const int simd = simd_level();
  if (!(simd >= 2 || (simd >= 1 && cpu_has_fma()))) return false;
  const PixelBlock block = simd >= 2 ? avx512 : avx2;
  constexpr std::size_t kB = 256;
  alignas(64) double redo[kB];
  for (std::size_t s = 0; s < count; s += kB) {
    const std::size_t m = std::min(kB, count - s);
    if (block(n + s, p + s, u + 2 * s, m, out + s, redo))
      for (std::size_t i = 0; i < m; ++i)
        if (redo[i] != 0.0) out[s + i] = eval(n[s + i], p[s + i], u + 2 * (s + i));
  }
  return true;
}
}  // namespace glintlab::detail
