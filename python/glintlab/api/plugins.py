"""Counting laws written in C or C++ and loaded at run time (ABI: core/include/glintlab/plugin.h).

A plugin is a shared library exporting ``glintlab_plugin_laws_v1``; see README.md, "Custom laws in
C++ (plugins)". Its laws are registered like built-in ones: ``law(name)``, ``laws()``,
``law_summaries()``, sampling (threads-independent), ``pmf`` when the plugin gives one, reports.
"""
from __future__ import annotations

import os

from .. import _core
from .registry import Registry
from . import checks as V

# Laws written in Python (``custom_law``), by name: plugins must not take their names.
CUSTOM_LAWS: Registry = Registry("custom law")


def load_plugin(path) -> list[str]:
    """Loads the plugin library at ``path`` (str or path-like; relative to the current directory)
    and returns the names of the laws it registered.

    Loading the same file again returns the same names and changes nothing; the library stays loaded
    until the process ends. Raises ValueError naming the path when the file is missing, cannot be
    loaded, does not export ``glintlab_plugin_laws_v1``, or has a bad table entry (invalid name,
    n_uniforms outside 0..4, no evaluate function, unknown binning, a name already used by a built-in
    law, another plugin or a custom law). Nothing of a rejected plugin is registered.
    """
    try:
        path = os.fspath(path)
    except TypeError:
        V.fail("path", path, "the path of a plugin library (str)")
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    return list(_core.load_plugin(path, sorted(CUSTOM_LAWS)))


def loaded_plugins() -> dict[str, list[str]]:
    """Plugins loaded in this process: canonical library path -> names of its laws."""
    return {path: list(names) for path, names in _core.loaded_plugins()}
