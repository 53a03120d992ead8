// LevelLadder::brackets's vector passes for baseline (level_brackets_body.inc); the dispatch is in level_brackets.cpp.
#define GLINTLAB_LEVEL_PASSES level_passes_baseline
#define GLINTLAB_LEVEL_WEIGHTS level_weights_baseline
#define GLINTLAB_SNAP_TRIALS snap_trial_rows_baseline
#include "level_brackets_body.inc"
