// simd_math.hpp's kernels for avx512: this file alone is compiled with the ISA's flags (CMakeLists.txt)
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
  for (; i + 8 <= count; i += 8) _mm512_storeu_pd(y + i, F(_mm512_loadu_pd(x + i)));
  if (i < count) {  // the tail through a padded vector (1.0 pads: finite for every op)
    alignas(64) double in[8], out[8];
    for (std::size_t j = 0; j < 8; ++j) in[j] = i + j < count ? x[i + j] : 1.0;
    _mm512_storeu_pd(out, F(_mm512_loadu_pd(in)));
    for (std::size_t j = 0; i + j < count; ++j) y[i + j] = out[j];
  }
}
}  // namespace

void vec_math_avx512(int op, const double* x, double* y, std::size_t count) {
  switch (op) {
    case 0: apply<Sleef_logd8_u10avx512f>(x, y, count); break;
    case 1: apply<Sleef_log1pd8_u10avx512f>(x, y, count); break;
    case 2: apply<Sleef_expd8_u10avx512f>(x, y, count); break;
    case 3: apply<Sleef_expm1d8_u10avx512f>(x, y, count); break;
    case 4: apply<Sleef_sind8_u10avx512f>(x, y, count); break;
    default: apply<Sleef_cosd8_u10avx512f>(x, y, count); break;
  }
}

}  // namespace glintlab::detail
