"""The image methods' glinty NDFs under their historical module name (docs/math/glint_images.md): the
smooth target (:class:`SmoothNDF`) and the facet ground truth (:class:`FacetNDF`, :func:`facet_counts`)
are glinty NDFs like the others and live in ``glintlab.api.glinty_ndf`` (one base class, one pixel-array
check, one D_P, one registry of image methods).

>>> import numpy as np, glintlab as gl
>>> from glintlab.api.image_ndfs import FacetNDF
>>> f = FacetNDF(density=1e4, target="beckmann", alpha=0.5)
>>> uv = np.array([[0.3, 0.4]]); J = np.array([[0.05, 0.0, 0.0, 0.05]]); h = np.array([[0.0, 0.0, 1.0]])
>>> float(f.evaluate(uv, J, h, seed=1)[0]) >= 0
True
"""
from __future__ import annotations

from .glinty_ndf import FACET_STATUS, FacetNDF, SmoothNDF, facet_counts

__all__ = ["FACET_STATUS", "FacetNDF", "SmoothNDF", "facet_counts"]
