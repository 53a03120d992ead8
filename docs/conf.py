"""Sphinx configuration: the API reference (docs/api, from the docstrings), the Markdown pages
(docs/*.md, docs/math/*.md, through MyST) and the notebooks (notebooks/*.ipynb, rendered as stored,
never executed).

Build with ``make docs`` (the venv's interpreter, so the compiled ``glintlab._core`` imports):
``.venv/bin/python -m sphinx -W --keep-going -b html docs out/docs``.
"""
from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

import glintlab

ROOT = Path(__file__).resolve().parent.parent

project = "glintlab"
author = "glintlab contributors"
copyright = "glintlab contributors"
version = release = glintlab.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",
    "nbsphinx",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "figures", "**/.ipynb_checkpoints"]
suppress_warnings = []

# MyST: (label)= anchors and {ref} roles are core syntax; headings get anchors for [](page.md#slug) links.
myst_heading_anchors = 3

# autodoc: the docstrings are plain reST (double-backquoted names, no Google/NumPy sections).
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_preserve_defaults = True  # show ``seed=None``, ``size=10**6`` as written, not evaluated

# furo (Debian's package, scripts/install-deps.sh): a content column wide enough for the code examples
# (alabaster clipped the front page's at 520 pixels), a sidebar of every page, light and dark.
html_theme = "furo"
html_title = f"glintlab {release}"
html_static_path: list[str] = []

# The notebooks: docs/notebooks is a symbolic link to notebooks/ (Sphinx reads only under docs/). They
# are stored without outputs and shown as stored, code and text: never executed here (test_notebooks.py
# runs them). nbsphinx converts their Markdown cells with pandoc (scripts/install-deps.sh installs it).
nbsphinx_execute = "never"


def _submodules(package: str) -> list[str]:
    """``package`` and every public module below it (names with a leading underscore skipped), in
    name order, packages before their modules."""
    pkg = importlib.import_module(package)
    names = [package]
    if hasattr(pkg, "__path__"):
        for info in sorted(pkgutil.iter_modules(pkg.__path__, package + "."), key=lambda m: m.name):
            if not info.name.rsplit(".", 1)[1].startswith("_"):
                names += _submodules(info.name)
    return names


class AutoPackage(SphinxDirective):
    """``.. autopackage:: glintlab.validation``: one section per public module of the package, each
    an ``automodule`` with its members, so a module that a layer gains appears without an edit here.
    ``:exclude:`` takes module names to leave out (space separated)."""

    required_arguments = 1
    option_spec = {"exclude": lambda arg: (arg or "").split()}

    def run(self):
        exclude = set(self.options.get("exclude", []))
        lines = StringList()
        source = self.get_source_info()[0]
        for name in _submodules(self.arguments[0]):
            module = importlib.import_module(name)
            if hasattr(module, "__path__"):  # a package: its folder's mtime changes when a module comes or goes
                self.env.note_dependency(module.__path__[0])
            if name in exclude:
                continue
            for line in (f".. _api-{name}:", "", name, "-" * len(name), "",
                         f".. automodule:: {name}", "   :members:", ""):
                lines.append(line, source)
        node = nodes.Element()
        nested_parse_with_titles(self.state, lines, node)
        return node.children


# The docstrings are written to read well in ``help()``: plain-text mathematics with bars for absolute
# values (``|x - y|``), and aligned two-column lists of parameters or cases, whose descriptions wrap
# onto lines indented to the description's column. The hook below makes both valid reST: bars outside
# literals are escaped (reST would read ``|x|`` as a substitution), and an aligned list becomes a
# definition list. Literal blocks (after ``::``) and doctest blocks (``>>>``) are left as they are.
_LITERAL = re.compile(r"(``.+?``|`[^`]+`)")
_ENTRY = re.compile(r"^(?P<term>\S(?:.{0,22}?\S)?) {2,}(?P<desc>\S.*)$")


def _escape_bars(line: str) -> str:
    parts = _LITERAL.split(line)
    return "".join(x if i % 2 else re.sub(r"(?<!\\)\|", r"\\|", x) for i, x in enumerate(parts))


def _aligned_list(paragraph: list[str]) -> list[str] | None:
    """``paragraph`` as a definition list if it is an aligned two-column list (two or more entries,
    or one whose description wraps), else None."""
    first = _ENTRY.match(paragraph[0]) if paragraph else None
    if not first:
        return None
    column = first.start("desc")
    entries: list[list[str]] = []
    wrapped = False
    for line in paragraph:
        m = _ENTRY.match(line)
        if m and m.start("desc") == column:
            entries.append([m["term"], m["desc"]])
        elif len(line) - len(line.lstrip(" ")) == column:
            entries[-1].append(line.strip())
            wrapped = True
        else:
            return None
    if len(entries) < 2 and not wrapped:
        return None
    return [out for term, *desc in entries for out in [term, *("   " + d for d in desc)]]


def _plain_text_docstring(app, what, name, obj, options, lines: list[str]) -> None:
    out: list[str] = []
    paragraph: list[str] = []
    literal_indent = None  # indentation of the paragraph that announced a literal block (``::``)
    doctest = False

    def flush():
        out.extend(_aligned_list(paragraph) or paragraph)
        paragraph.clear()

    for line in lines:
        indent = len(line) - len(line.lstrip())
        if not line.strip():
            flush()
            doctest = False
            out.append(line)
            continue
        if literal_indent is not None:
            if indent > literal_indent:
                out.append(line)
                continue
            literal_indent = None
        if doctest or line.lstrip().startswith(">>>"):
            flush()
            doctest = True
            out.append(line)
            continue
        paragraph.append(_escape_bars(line))
        if line.rstrip().endswith("::"):
            flush()
            literal_indent = indent
    flush()
    lines[:] = out


def setup(app):
    app.add_directive("autopackage", AutoPackage)
    app.connect("autodoc-process-docstring", _plain_text_docstring)
    return {"parallel_read_safe": True}
