"""The one registry of image methods (docs/math/glint_images.md#glint-methods): an image method is a
factory ``material -> glinty NDF`` registered by name (:func:`register_image_method`) with everything the
scene images, the report and the generic tests read of it (:class:`ImageMethod`), and the material it is
bound to (:class:`Material`).

The glinty NDFs and the registrations of the methods glintlab ships are in :mod:`glintlab.api.glinty_ndf`
(which re-exports these names, their historical import path), the method shaders' in
:mod:`glintlab.api.method_shaders`, :mod:`glintlab.api.counting_shaders` and :mod:`glintlab.api.zk16_shaders`.
This module imports none of them, so any of them can register here.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

from . import checks as V
from .registry import Registry


ANGULAR_TEXEL = 0.05  # slope units: the angular life span of a glint (docs/math/glint_images.md#glint-angular)


@dataclass(frozen=True)
class Material:
    """What an image method needs of a scene's material: facet density N (per unit texture area), the
    target NDF (``target``, ``alpha``), DB23's ratio R and the angular texel size (slope units)."""
    density: float
    target: str
    alpha: float
    R: float
    angular_texel: float = ANGULAR_TEXEL

    @classmethod
    def of(cls, scene, angular_texel: float = ANGULAR_TEXEL) -> "Material":
        """The material of ``scene`` (its JSON ``material``)."""
        m = scene.spec["material"]
        return cls(float(m["density"]), m["ndf"], float(m["alpha"]), float(m["R"]),
                   V.real("angular_texel", angular_texel))


@dataclass(frozen=True)
class ImageMethod:
    """A registered image method, everything the scene images, the report and the generic tests read of
    it (tests/python/test_extension_registries.py): ``factory(material)`` returns a :class:`GlintyNDF`
    (or any object with ``evaluate(uv, J, h, seed)``); ``label`` is the figure's name for it; ``truth``
    is the kind of the method's own truth, what its flicker and pops are read against
    (docs/math/glint_images.md#glint-own-truth): "self" (the method is the facet ground truth), "facets"
    (the stratified facet truth), "reference" (the evaluator's ``reference(uv, J, h, seed)``: the exact
    model on the same realization) or "supersampled" (the same method box-filtered over 4 x 4
    sub-pixels); ``returns`` is "ndf" (an NDF value per pixel) or "intensity" (a method shader's output);
    ``origin`` says who registered it (``ORIGINS``): "glintlab" (a method glintlab ships),
    "shader_method" (a user's method shader, which a later ``shader_method`` of the same name replaces)
    or "user" (any other registration); ``density(material)``, when given, is the density the method
    runs at (its mapping to the facet truth's expected glint count,
    docs/math/glint_images.md#glint-own-truth), else the material's N; ``panel``: whether the scene
    images' panel renders it by default (the report's first section); ``doc``: the section documenting
    it (a page and its anchor, as docs/math/glint_images.md#glint-methods: a method glintlab ships has
    one, and it names the method); ``shader``: a shipped method shader's files, twin comparison and
    deliberately wrong variants (``method_shaders.ShippedShader``), None for any other method."""
    name: str
    label: str
    factory: Callable
    truth: str = "facets"
    returns: str = "ndf"
    origin: str = "user"
    density: Callable | None = None
    panel: bool = True
    doc: str | None = None
    shader: object = None

    @property
    def is_truth(self) -> bool:
        """Whether the method is the facet ground truth itself."""
        return self.truth == "self"


IMAGE_METHODS: Registry = Registry("image method")


TRUTH_KINDS = ("self", "facets", "reference", "supersampled")
ORIGINS = ("glintlab", "shader_method", "user")


def _defined_in_glintlab(factory) -> bool:
    """Whether ``factory`` (a function, a lambda or a functools.partial of one) is glintlab's own code."""
    func = getattr(factory, "func", factory)
    return (getattr(func, "__module__", None) or "").split(".")[0] == "glintlab"


def register_image_method(name: str, factory: Callable, label: str | None = None, truth=None,
                          replace: bool = False, returns: str = "ndf", origin: str | None = None,
                          density: Callable | None = None, panel: bool | None = None, doc: str | None = None,
                          shader=None) -> ImageMethod:
    """Adds an image method: ``factory(material)`` -> a glinty NDF; returns its entry (:class:`ImageMethod`,
    whose fields the other arguments are). ``truth``: the kind of its own truth (``TRUTH_KINDS``; True
    means "self", the ground truth itself); default "facets" for an NDF method, "supersampled" for an
    intensity method. ``origin`` (``ORIGINS``): who registers it; default "glintlab" for a factory
    defined in glintlab's package (its shipped methods), "user" otherwise. ``panel``: default True for
    an NDF method (the scene images render it by default, registered before or after them), False for
    an intensity method. A name registered before is refused unless ``replace``."""
    if not callable(factory):
        V.fail("factory", factory, "a callable material -> evaluator")
    if density is not None and not callable(density):
        V.fail("density", density, "None or a callable material -> density")
    if origin is None:
        origin = "glintlab" if _defined_in_glintlab(factory) else "user"
    V.choice("origin", origin, ORIGINS)
    V.choice("returns", returns, ("ndf", "intensity"), "'ndf' or 'intensity'")
    if truth is None or truth is False:
        truth = "facets" if returns == "ndf" else "supersampled"
    elif truth is True:
        truth = "self"
    if truth not in TRUTH_KINDS:
        V.fail("truth", truth, f"one of {', '.join(TRUTH_KINDS)} (or True for the ground truth itself)")
    panel = returns == "ndf" if panel is None else bool(panel)
    entry = ImageMethod(name, label or name, factory, truth, returns, origin, density, panel, doc, shader)
    return IMAGE_METHODS.register(name, entry, replace=replace)


def shipped_image_methods() -> list[str]:
    """The image methods glintlab ships (``origin`` "glintlab"): the glinty NDFs, WB16's and the counting
    method shaders, WWH18; no method shader may take one of these names."""
    return [n for n in IMAGE_METHODS.names() if IMAGE_METHODS.get(n).origin == "glintlab"]


def image_methods(returns: str | None = None) -> list[str]:
    """Names of every registered image method, built-in and registered (``gl.image_methods()``); with
    ``returns`` ("ndf" or "intensity") only those of that kind."""
    if returns is None:
        return IMAGE_METHODS.names()
    V.choice("returns", returns, ("ndf", "intensity"), "None, 'ndf' or 'intensity'")
    return [n for n in IMAGE_METHODS.names() if IMAGE_METHODS.get(n).returns == returns]


def panel_methods() -> list[str]:
    """The image methods the scene images' panel renders by default: every registered one whose entry
    says ``panel`` (the NDF methods unless registered otherwise), read when called, so a method
    registered after glintlab's import is rendered too."""
    return [n for n in IMAGE_METHODS.names() if IMAGE_METHODS.get(n).panel]


def method_density(name: str, material: Material) -> float:
    """The density image method ``name`` runs at for ``material``: its entry's ``density(material)`` (its
    mapping to the facet truth's glint count) or the material's N."""
    f = IMAGE_METHODS.get(name).density
    return float(f(material)) if f is not None else material.density


def make_method(name: str, material: Material):
    """The evaluator (a glinty NDF) of image method ``name`` for ``material`` (at its matched density)."""
    entry = IMAGE_METHODS.get(name)
    if entry.density is not None and material is not None:
        material = dataclasses.replace(material, density=method_density(name, material))
    return entry.factory(material)
