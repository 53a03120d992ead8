// The roulette's row kernels (roulette_rows_body.inc) at the portable level, and their dispatch by
// detail::simd_level().
#include "glintlab/detail/roulette.hpp"
#include "glintlab/detail/uniform_rows.hpp"

#define GLINTLAB_ROULETTE_ROWS roulette_normal_rows_portable
#define GLINTLAB_QUANTILE_CENTRAL normal_quantile_central_portable
#define GLINTLAB_QUANTILE_WITH_LOG normal_quantile_with_log_portable
#define GLINTLAB_NORMAL_KEPT roulette_normal_kept_portable
#include "roulette_rows_body.inc"

namespace glintlab::detail {

void roulette_normal_rows(RouletteRows& rows) {
  const int level = simd_level();
  if (level >= 2) return roulette_normal_rows_avx512(rows);
  if (level >= 1) return roulette_normal_rows_avx2(rows);
  roulette_normal_rows_portable(rows);
}

void normal_quantile_central(const double* u, std::size_t count, double* out) {
  const int level = simd_level();
  if (level >= 2) return normal_quantile_central_avx512(u, count, out);
  if (level >= 1) return normal_quantile_central_avx2(u, count, out);
  normal_quantile_central_portable(u, count, out);
}

void normal_quantile_with_log(const double* u, const double* log_tail, std::size_t count, double* out) {
  const int level = simd_level();
  if (level >= 2) return normal_quantile_with_log_avx512(u, log_tail, count, out);
  if (level >= 1) return normal_quantile_with_log_avx2(u, log_tail, count, out);
  normal_quantile_with_log_portable(u, log_tail, count, out);
}

void roulette_normal_kept(const double* k, const double* mom0, const double* mom1, const double* u,
                          const double* log_tail, std::size_t count, double* out) {
  const int level = simd_level();
  if (level >= 2) return roulette_normal_kept_avx512(k, mom0, mom1, u, log_tail, count, out);
  if (level >= 1) return roulette_normal_kept_avx2(k, mom0, mom1, u, log_tail, count, out);
  roulette_normal_kept_portable(k, mom0, mom1, u, log_tail, count, out);
}

}  // namespace glintlab::detail
