// The roulette's row kernels (roulette_rows_body.inc) for AVX2; called only when the CPU has it.
#define GLINTLAB_ROULETTE_ROWS roulette_normal_rows_avx2
#define GLINTLAB_QUANTILE_CENTRAL normal_quantile_central_avx2
#define GLINTLAB_QUANTILE_WITH_LOG normal_quantile_with_log_avx2
#define GLINTLAB_NORMAL_KEPT roulette_normal_kept_avx2
#include "roulette_rows_body.inc"
