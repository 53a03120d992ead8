// LevelLadder::brackets's vector passes for avx2 (level_brackets_body.inc); the dispatch is in level_brackets.cpp.
#define GLINTLAB_LEVEL_PASSES level_passes_avx2
#define GLINTLAB_LEVEL_WEIGHTS level_weights_avx2
#define GLINTLAB_SNAP_TRIALS snap_trial_rows_avx2
#include "level_brackets_body.inc"
