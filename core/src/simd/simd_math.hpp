// Private helper of the core: elementwise log, log1p, exp and expm1 over arrays, by SLEEF's vector
// functions (Debian's libsleef-dev; 1.0-ulp "u10" variants) at the SIMD level in effect
// (detail::simd_level(): AVX-512, AVX2, else the C library's scalar functions).
//
// These are NOT bit-identical to the C library's functions (up to 1 ulp apart). Callers use them
// only to decide quickly, with a guard band wide enough for that difference, and recompute with the
// exact scalar expressions whenever a result lies within the band of a decision threshold, so that
// the laws' outputs stay bit-identical to their scalar evaluate() (see gated.cpp's evaluate_pixels).
#pragma once

#include <cstddef>

#include "glintlab/detail/pixel_blocks.hpp"  // the laws' block functions and cpu_has_fma, defined here

namespace glintlab::detail {

void vec_log(const double* x, double* y, std::size_t count);
void vec_log1p(const double* x, double* y, std::size_t count);
void vec_exp(const double* x, double* y, std::size_t count);
void vec_expm1(const double* x, double* y, std::size_t count);
// sin and cos (SLEEF's 1.0-ulp functions; Scene.trace's heightfield march, core/src/scene/scene_trace.cpp).
void vec_sin(const double* x, double* y, std::size_t count);
void vec_cos(const double* x, double* y, std::size_t count);

// The per-ISA kernels (simd_math_avx512.cpp, simd_math_avx2.cpp: compiled with those ISAs, called
// only when the CPU has them). op: 0 log, 1 log1p, 2 exp, 3 expm1, 4 sin, 5 cos.
void vec_math_avx512(int op, const double* x, double* y, std::size_t count);
void vec_math_avx2(int op, const double* x, double* y, std::size_t count);

}  // namespace glintlab::detail

namespace glintlab::detail {
// head_cf's per-pixel arithmetic after the vector logarithms (head_cf_pixels_body.inc), per ISA: the
// second half of its block functions (declared with the other laws' in detail/pixel_blocks.hpp).
void head_cf_pixels_avx512(const double* n, const double* p, const double* u, const double* e, const double* lt,
                           std::size_t count, double* out, double* redo);
void head_cf_pixels_avx2(const double* n, const double* p, const double* u, const double* e, const double* lt,
                         std::size_t count, double* out, double* redo);
}  // namespace glintlab::detail
