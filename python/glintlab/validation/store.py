"""The resumable store of a sweep: a JSON-lines file whose first line holds the sweep's configuration
(and its hash, the key) and whose every other line is one finished row, flushed to the operating system
as soon as the row is done. A run interrupted by Ctrl-C or ``kill -9`` loses no finished row; the same
sweep run again computes only the missing rows."""
from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path

from .._core import __version__ as _version
from ..api import checks as V

# 2: the configuration holds each law's identity (format 1 keyed custom laws by name only).
# 3: the mollified roulette blend's keep moments in closed form (format 2 used Gauss-Kronrod
#    quadrature, an ulp or so away): its samples differ in their last bits, so rows of a format-2
#    store would not be reproduced by this version.
STORE_FORMAT = 3
_FORMAT_CHANGE = {2: "the mollified roulette's samples changed in their last bits",
                  1: "the configuration records each law's identity, and the mollified roulette's samples "
                     "changed in their last bits"}


class SweepStore:
    """A resumable store of finished rows (see the module docstring)."""

    def __init__(self, path, config: dict):
        self.path = Path(path)
        self.config = config
        self.key = hashlib.sha256(json.dumps(config, sort_keys=True).encode()).hexdigest()
        self.rows: dict[tuple, dict] = {}
        self._last_sync = time.monotonic()
        if self.path.exists() and self.path.stat().st_size > 0:
            self._load()
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            header = {"glintlab_store": STORE_FORMAT, "glintlab_version": _version, "key": self.key,
                      "config": config}
            with open(self.path, "w") as f:
                f.write(json.dumps(header) + "\n")
                f.flush()
                os.fsync(f.fileno())
        self._file = open(self.path, "a")

    def _load(self):
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        try:
            header = json.loads(lines[0])
        except ValueError:
            header = None
        if isinstance(header, dict) and isinstance(header.get("glintlab_store"), int) \
                and header["glintlab_store"] != STORE_FORMAT:
            why = _FORMAT_CHANGE.get(header["glintlab_store"], "a different layout")
            raise ValueError(f"store = {str(self.path)!r} was written in store format {header['glintlab_store']} "
                             f"(this glintlab writes format {STORE_FORMAT}: {why}); "
                             "use another store path, or delete it to start over")
        if not isinstance(header, dict) or header.get("glintlab_store") != STORE_FORMAT:
            V.fail("store", str(self.path), "a glintlab sweep store (a JSON-lines file written by sweep(store=...))")
        if header.get("key") != self.key:
            old = header.get("config", {})
            diff = sorted(k for k in set(old) | set(self.config) if old.get(k) != self.config.get(k))
            raise ValueError(f"store = {str(self.path)!r} holds a different sweep (differs in: {', '.join(diff)}); "
                             "use another store path, or delete it to start over")
        # Complete lines end with a newline; what follows the last one was cut by a kill: it is
        # dropped (cut from the file) and its row recomputed.
        if len(lines) == 1:  # the header's newline never reached the file
            with open(self.path, "ab") as f:
                f.write(b"\n")
            return
        good_end = len(lines[0]) + 1
        for line in lines[1:-1]:
            if line:
                try:
                    row = json.loads(line)
                except ValueError:
                    break
                self.rows[row_key(row)] = row
            good_end += len(line) + 1
        if good_end < len(raw):
            with open(self.path, "r+b") as f:
                f.truncate(good_end)

    def add(self, row: dict):
        self._file.write(json.dumps(row) + "\n")
        self._file.flush()  # in the kernel's hands: survives kill -9 of this process
        self.rows[row_key(row)] = row
        if time.monotonic() - self._last_sync > 1.0:  # and on disk, about once a second
            os.fsync(self._file.fileno())
            self._last_sync = time.monotonic()

    def close(self):
        if not self._file.closed:
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()


def row_key(row) -> tuple:
    """A row's identity in a store: (law label, n, p), floats exact (hex)."""
    return (row["law"], float(row["n"]).hex(), float(row["p"]).hex())
