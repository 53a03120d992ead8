"""Idle OpenMP workers sleep instead of spinning: sets ``OMP_WAIT_POLICY=passive`` unless the environment
sets it, before ``glintlab._core`` loads the OpenMP runtime (which reads it once, when it loads). On a
machine shared with other jobs, workers that spin after each batch use up their time slices and are
late for the next batch, which waits for them: a batch of 1e5 draws took 10-40 ms with two spinning
threads against 0.2-1 ms with one, and as long as one thread's with passive workers
(docs/guide/performance.md#threads-on-a-loaded-machine). Imported first by the package's ``__init__``;
without effect when another library loaded the runtime earlier in the process (then set the variable
in the environment)."""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "passive")
