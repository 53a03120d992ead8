"""What every pytest test of tests/python shares: no test's registrations reach another test.

A test that registers an image method, a glinty NDF, a custom law, a sampler or a report section (and
fails, or forgets, to remove it) would otherwise change what ``gl.image_methods()`` and the other lists
return for every later test of the same process, so that the suite's verdict depended on which files
run together and in what order. Every ``Registry`` (glintlab.api.registry: the image methods with
their density mappings among them) is snapshot before each test and restored after it.
"""
from __future__ import annotations

import pytest

from glintlab.api.registry import Registry


@pytest.fixture(autouse=True)
def _restore_registries():
    registries = Registry.snapshot_all()
    yield
    Registry.restore_all(registries)
