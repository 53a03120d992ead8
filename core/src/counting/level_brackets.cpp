// Dispatch of LevelLadder::brackets's vector passes by detail::simd_level() (level_brackets_body.inc).
#include "level_brackets.hpp"

#include "glintlab/detail/uniform_rows.hpp"

namespace glintlab::detail {

void level_passes(const double* a, std::size_t m, const LadderTable& t, int* lo, double* area_lo, double* area_hi,
                  double* ratio) {
  const int level = simd_level();
  if (level >= 2) return level_passes_avx512(a, m, t, lo, area_lo, area_hi, ratio);
  if (level >= 1) return level_passes_avx2(a, m, t, lo, area_lo, area_hi, ratio);
  level_passes_baseline(a, m, t, lo, area_lo, area_hi, ratio);
}

void level_weights(const double* a, std::size_t m, double log_ratio, const double* area_lo, const double* area_hi,
                   double* w_lod, double* w_area) {
  const int level = simd_level();
  if (level >= 2) return level_weights_avx512(a, m, log_ratio, area_lo, area_hi, w_lod, w_area);
  if (level >= 1) return level_weights_avx2(a, m, log_ratio, area_lo, area_hi, w_lod, w_area);
  level_weights_baseline(a, m, log_ratio, area_lo, area_hi, w_lod, w_area);
}

void snap_trial_rows(double* t_lo, double* t_hi, std::size_t m) {
  const int level = simd_level();
  if (level >= 2) return snap_trial_rows_avx512(t_lo, t_hi, m);
  if (level >= 1) return snap_trial_rows_avx2(t_lo, t_hi, m);
  snap_trial_rows_baseline(t_lo, t_hi, m);
}

}  // namespace glintlab::detail
