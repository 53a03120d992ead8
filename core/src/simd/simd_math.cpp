// Dispatch of simd_math.hpp's array functions by detail::simd_level().
#include "simd_math.hpp"

#include <cmath>

#include "glintlab/detail/uniform_rows.hpp"

namespace glintlab::detail {

bool cpu_has_fma() {
  static const bool fma = __builtin_cpu_supports("fma");
  return fma;
}

namespace {
void dispatch(int op, const double* x, double* y, std::size_t count) {
  const int level = simd_level();
  if (level >= 2) return vec_math_avx512(op, x, y, count);
  // SLEEF's AVX2 functions use FMA3, which every AVX2 CPU of Intel and AMD has; checked anyway.
  if (level >= 1 && cpu_has_fma()) return vec_math_avx2(op, x, y, count);
  switch (op) {
    case 0:
      for (std::size_t i = 0; i < count; ++i) y[i] = std::log(x[i]);
      break;
    case 1:
      for (std::size_t i = 0; i < count; ++i) y[i] = std::log1p(x[i]);
      break;
    case 2:
      for (std::size_t i = 0; i < count; ++i) y[i] = std::exp(x[i]);
      break;
    case 3:
      for (std::size_t i = 0; i < count; ++i) y[i] = std::expm1(x[i]);
      break;
    case 4:
      for (std::size_t i = 0; i < count; ++i) y[i] = std::sin(x[i]);
      break;
    default:
      for (std::size_t i = 0; i < count; ++i) y[i] = std::cos(x[i]);
      break;
  }
}
}  // namespace

void vec_log(const double* x, double* y, std::size_t count) { dispatch(0, x, y, count); }
void vec_log1p(const double* x, double* y, std::size_t count) { dispatch(1, x, y, count); }
void vec_exp(const double* x, double* y, std::size_t count) { dispatch(2, x, y, count); }
void vec_expm1(const double* x, double* y, std::size_t count) { dispatch(3, x, y, count); }
void vec_sin(const double* x, double* y, std::size_t count) { dispatch(4, x, y, count); }
void vec_cos(const double* x, double* y, std::size_t count) { dispatch(5, x, y, count); }

}  // namespace glintlab::detail
