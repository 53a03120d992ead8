// simd_math.hpp's kernels for avx2: this file alone is compiled with the ISA's flags (CMakeLists.txt)
// and is called only when the CPU has it (simd_math.cpp). It holds nothing but SLEEF calls on
// intrinsic vectors (no inline function of a shared header that the linker could pick up for
// another translation unit).
#include <immintrin.h>
#include <sleef.h>

#include "simd_math.hpp"

namespace glintlab::detail {

namespace {
template <auto F>
void apply(const double* x, double* y, std::size_t count) {
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) _mm256_storeu_pd(y + i, F(_mm256_loadu_pd(x + i)));
  if (i < count) {  // the tail through a padded vector (1.0 pads: finite for every op)
    alignas(64) double in[4], out[4];
    for (std::size_t j = 0; j < 4; ++j) in[j] = i + j < count ? x[i + j] : 1.0;
    _mm256_storeu_pd(out, F(_mm256_loadu_pd(in)));
    for (std::size_t j = 0; i + j < count; ++j) y[i + j] = out[j];
  }
}
}  // namespace

void vec_math_avx2(int op, const double* x, double* y, std::size_t count) {
  switch (op) {
    case 0: apply<Sleef_logd4_u10avx2>(x, y, count); break;
    case 1: apply<Sleef_log1pd4_u10avx2>(x, y, count); break;
    case 2: apply<Sleef_expd4_u10avx2>(x, y, count); break;
    case 3: apply<Sleef_expm1d4_u10avx2>(x, y, count); break;
    case 4: apply<Sleef_sind4_u10avx2>(x, y, count); break;
    default: apply<Sleef_cosd4_u10avx2>(x, y, count); break;
  }
}

}  // namespace glintlab::detail
