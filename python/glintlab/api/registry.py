"""A registry of named things (report sections, custom laws): one name, one object, in registration order."""
from __future__ import annotations

import weakref

from . import checks as V


class Registry:
    """Objects by name. ``kind`` names what is registered in error messages ("report section", "law").

    >>> r = Registry("colour")
    >>> r.register("red", 1)
    1
    >>> r.get("blue")
    Traceback (most recent call last):
    ValueError: unknown colour 'blue'; known: red
    """

    # Every live registry, for snapshot_all / restore_all (a registry built and dropped, as a report's
    # discovery may do, leaves the set by itself).
    _instances: "weakref.WeakSet[Registry]" = weakref.WeakSet()

    def __init__(self, kind: str):
        self.kind = kind
        self._items: dict = {}
        Registry._instances.add(self)

    def snapshot(self) -> dict:
        """The registry's entries (a copy, in order), for :meth:`restore`."""
        return dict(self._items)

    def restore(self, snapshot: dict) -> None:
        """Puts back the entries of an earlier :meth:`snapshot`: names registered since are removed,
        names replaced or removed since get their earlier objects back."""
        self._items = dict(snapshot)

    @classmethod
    def snapshot_all(cls) -> list[tuple]:
        """A snapshot of every live registry (image methods, glinty NDFs, custom laws, samplers, report
        sections, ...): what a test suite restores after each test so that one test's registrations
        never reach another (tests/python/conftest.py).

        >>> r = Registry("colour")
        >>> saved = Registry.snapshot_all()
        >>> r.register("red", 1)
        1
        >>> Registry.restore_all(saved)
        >>> r.names()
        []
        """
        return [(registry, registry.snapshot()) for registry in list(cls._instances)]

    @classmethod
    def restore_all(cls, snapshots: list[tuple]) -> None:
        """Restores each registry of :meth:`snapshot_all`'s result (registries created since are left as
        they are)."""
        for registry, snapshot in snapshots:
            registry.restore(snapshot)

    def register(self, name: str, obj, replace: bool = False):
        """Adds ``obj`` under ``name`` and returns it. A name registered before is refused (ValueError)
        unless ``replace`` (then ``obj`` takes the name's place, keeping its position)."""
        if not isinstance(name, str) or not name:
            V.fail(f"{self.kind} name", name, "a non-empty string")
        if name in self._items and not replace:
            raise ValueError(f"{self.kind} {name!r} is already registered")
        self._items[name] = obj
        return obj

    def get(self, name: str):
        try:
            return self._items[name]
        except (KeyError, TypeError):
            raise ValueError(f"unknown {self.kind} {name!r}; known: {', '.join(self._items)}") from None

    def names(self) -> list[str]:
        return list(self._items)

    def items(self) -> list[tuple]:
        return list(self._items.items())

    def __contains__(self, name) -> bool:
        return name in self._items

    def __iter__(self):
        return iter(list(self._items))

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._items)})"
