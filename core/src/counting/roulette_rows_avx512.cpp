// The roulette's row kernels (roulette_rows_body.inc) for AVX-512; called only when the CPU has it.
#define GLINTLAB_ROULETTE_ROWS roulette_normal_rows_avx512
#define GLINTLAB_QUANTILE_CENTRAL normal_quantile_central_avx512
#define GLINTLAB_QUANTILE_WITH_LOG normal_quantile_with_log_avx512
#define GLINTLAB_NORMAL_KEPT roulette_normal_kept_avx512
#include "roulette_rows_body.inc"
