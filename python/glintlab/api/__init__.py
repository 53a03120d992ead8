"""The thin API over the C++ core (``glintlab._core``): laws, blends, anisotropic grids, ground truth,
metrics, target NDFs, plugins, and the argument checks every public function shares.

Nothing here runs an experiment or writes a file; the validation layer builds on it.
"""
