// A law's vector per-pixel pass (detail::LawKernel::evaluate_pixels): the per-ISA block functions of
// the laws that have one (compiled from core/src/simd/<law>_pixels_body.inc with the ISA's flags, called
// only on CPUs that have it) and the one driver that runs them, for the law files (core/laws/).
//
// The ISA-compiled files include this header for the declarations only: they never instantiate
// run_pixel_blocks, so no AVX-512 copy of it exists that the linker could pick for other callers.
#pragma once

#include <algorithm>
#include <cstddef>

#include "glintlab/detail/uniform_rows.hpp"  // detail::simd_level

namespace glintlab::detail {

// A law's per-pixel block function: a block of at most 256 pixels with two uniforms each; writes a
// count per pixel, and redo[i] != 0 where the law's eval must recompute it (the vector arithmetic
// could decide otherwise there); true when some redo[i] != 0.
using PixelBlock = bool (*)(const double* n, const double* p, const double* u, std::size_t m, double* out,
                            double* redo);

// The block functions per law and ISA (core/src/simd/gated_pixels_avx512.cpp, gated_pixels_avx2.cpp).
// The AVX2 ones need FMA3 too (SLEEF's AVX2 functions).
bool gated_pixels_block_avx512(const double* n, const double* p, const double* u, std::size_t m, double* out,
                               double* redo);
bool gated_pixels_block_avx2(const double* n, const double* p, const double* u, std::size_t m, double* out,
                             double* redo);
bool head_cf_pixels_block_avx512(const double* n, const double* p, const double* u, std::size_t count, double* out,
                                 double* redo);
bool head_cf_pixels_block_avx2(const double* n, const double* p, const double* u, std::size_t count, double* out,
                               double* redo);
// Whether SLEEF's AVX2 functions can run (FMA3).
bool cpu_has_fma();

// Runs `count` pixels through the block function of the CPU's ISA, 256 at a time, and recomputes the
// flagged ones with eval(n, p, u_row). False (nothing done) when the CPU has neither AVX-512 nor
// AVX2 with FMA3: the caller then evaluates every pixel (KernelLaw::evaluate_pixels).
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
