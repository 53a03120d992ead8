"""The C++ error vocabulary holds: bad input is reported through core/include/glintlab/base/errors.hpp
(throw_invalid, check_length, parse_enum, throw_invalid_message), never by a direct
``throw std::invalid_argument(`` in core/, validation/ or bindings/, so that each shape of bad input
has one message (as test_layout.py greps imports, this greps throws)."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HELPERS = {"core/include/glintlab/base/errors.hpp", "core/src/base/errors.cpp"}
# Files allowed a direct throw, each with its reason.
ALLOWED: dict[str, str] = {
    "validation/src/documents.cpp": "the document parser is its own library (glintlab_documents), built and fuzzed "
                                    "without glintlab_core, so it cannot link errors.cpp",
}
DIRECT = re.compile(r"throw\s+std::invalid_argument\s*\(")
LENGTH = re.compile(r"values; expected 1 or")


def sources():
    for folder in ("core", "validation", "bindings"):
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix in {".cpp", ".hpp", ".h", ".cc"}:
                yield path.relative_to(ROOT).as_posix(), path.read_text(encoding="utf-8", errors="replace")


def offenders(pattern):
    return [f"{name}:{text.count(chr(10), 0, m.start()) + 1}" for name, text in sources()
            if name not in HELPERS and name not in ALLOWED for m in pattern.finditer(text)]


def test_no_direct_invalid_argument_throws():
    found = offenders(DIRECT)
    assert not found, ("throw through glintlab/base/errors.hpp (throw_invalid, check_length, parse_enum or "
                       f"throw_invalid_message), not std::invalid_argument directly: {found}")


def test_one_length_message():
    assert not offenders(LENGTH), "use check_length (glintlab/base/errors.hpp) for 'has N values; expected 1 or M'"


def test_the_grep_finds_a_direct_throw():
    """The check can fail: the pattern matches the forms a direct throw is written in."""
    for code in ('throw std::invalid_argument("x");', "throw std::invalid_argument (msg);",
                 'if (bad) throw  std::invalid_argument(where + ": p");'):
        assert DIRECT.search(code), code
    assert not DIRECT.search("throw_invalid_message(msg);")
    names = {n for n, _ in sources()}
    assert all(path in names for path in HELPERS | set(ALLOWED))  # the lists name real files
