"""The exact binomial's batch path (one (n, p)) and per-pixel path (an (n, p) per sample) are
separate vector code; sample i is keyed by its index alone, so both must give the same draw for the
same (n, p, seed, i), bit for bit."""
import numpy as np
import pytest

import glintlab as gl

POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (60, 0.5), (59.5, 0.5), (1e6 + 0.5, 0.7),
          (1e15, 0.5), (2999.9, 0.01), (0.3, 0.2), (100, 1.0), (40, 0.97)]


@pytest.mark.parametrize("threads", [1, 2])
def test_pixels_equal_batches(threads):
    law = gl.law("binomial")
    size = 20_000
    old = gl.get_num_threads()
    gl.set_num_threads(threads)
    try:
        batches = {pt: law.sample(pt[0], pt[1], size=size, seed=7) for pt in POINTS}
        # Neighbouring samples get different points (no runs), so every sample takes the pixel path.
        which = np.arange(size) % len(POINTS)
        n = np.array([POINTS[w][0] for w in which])
        p = np.array([POINTS[w][1] for w in which])
        pixels = law.sample(n, p, seed=7)
    finally:
        gl.set_num_threads(old)
    for w, pt in enumerate(POINTS):
        idx = np.flatnonzero(which == w)
        np.testing.assert_array_equal(pixels[idx], batches[pt][idx], err_msg=f"(n, p) = {pt}")
