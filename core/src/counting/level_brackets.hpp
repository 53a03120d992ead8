// Private helper of blend.cpp: LevelLadder::brackets's vector passes, per ISA (level_brackets_body.inc).
#pragma once

#include <cstddef>

namespace glintlab::detail {

struct LadderTable {
  const double* areas;  // areas[l] = A_l for -tabulated <= l <= tabulated (a pointer to level 0)
  int tabulated;
  double base_area, inv_log2_ratio;
};

void level_passes(const double* a, std::size_t m, const LadderTable& t, int* lo, double* area_lo, double* area_hi,
                  double* ratio);
void level_weights(const double* a, std::size_t m, double log_ratio, const double* area_lo, const double* area_hi,
                   double* w_lod, double* w_area);

// blend.cpp's snap_trials on each row's pair, in place (the same bits).
void snap_trial_rows(double* t_lo, double* t_hi, std::size_t m);
void snap_trial_rows_avx512(double* t_lo, double* t_hi, std::size_t m);
void snap_trial_rows_avx2(double* t_lo, double* t_hi, std::size_t m);
void snap_trial_rows_baseline(double* t_lo, double* t_hi, std::size_t m);

void level_passes_avx512(const double* a, std::size_t m, const LadderTable& t, int* lo, double* area_lo,
                         double* area_hi, double* ratio);
void level_weights_avx512(const double* a, std::size_t m, double log_ratio, const double* area_lo,
                          const double* area_hi, double* w_lod, double* w_area);
void level_passes_avx2(const double* a, std::size_t m, const LadderTable& t, int* lo, double* area_lo, double* area_hi,
                       double* ratio);
void level_weights_avx2(const double* a, std::size_t m, double log_ratio, const double* area_lo, const double* area_hi,
                        double* w_lod, double* w_area);
void level_passes_baseline(const double* a, std::size_t m, const LadderTable& t, int* lo, double* area_lo,
                           double* area_hi, double* ratio);
void level_weights_baseline(const double* a, std::size_t m, double log_ratio, const double* area_lo,
                            const double* area_hi, double* w_lod, double* w_area);

}  // namespace glintlab::detail
