// The threads the core's batch drivers use (OpenMP), one setting for the whole library. Kept apart from
// the law header: the drivers of images, blends, samplers and NDFs need this knob, not the laws.
//
// Results never depend on it: every item of a batch draws its random numbers from its own index.
// Idle workers should sleep rather than spin: on a machine shared with other jobs a spinning worker
// uses up its time slice and is then late for the next batch, which waits for it
// (docs/guide/performance.md#threads-on-a-loaded-machine). The Python package sets
// OMP_WAIT_POLICY=passive before the OpenMP runtime loads, unless the environment sets it; a C++
// program sets it in its environment.
#pragma once

namespace glintlab {

// Threads used by the drivers (default: all cores, or GLINTLAB_NUM_THREADS). threads >= 1, else
// std::invalid_argument naming it.
void set_num_threads(int threads);
int num_threads();

}  // namespace glintlab
