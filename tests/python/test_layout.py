"""The package's layering holds: every module imports on its own in a fresh interpreter, in any order;
no module imports the package ``__init__``; imports between glintlab modules form no cycle; a layer
imports only the layers below it (api <- validation <- studies <- report <- cli); and no function hides
an import of a glintlab module (those dodged cycles)."""
from __future__ import annotations

import ast
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest

import glintlab

PACKAGE = Path(glintlab.__file__).resolve().parent
# A layer may import its own modules and those of the layers listed before it.
LAYERS = ["resources", "api", "validation", "studies", "report", "cli"]


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


# The compiled extension is a module too (it has no .py file).
MODULES = sorted([module_name(p) for p in PACKAGE.rglob("*.py")] + ["glintlab._core"])


def imports_of(path: Path):
    """(imported glintlab module or name, line, inside a function) for every import in the file."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    functions = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                 for n in ast.walk(f)}
    for node in ast.walk(tree):
        local = id(node) in functions
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target == "glintlab" or target.startswith("glintlab."):
                for alias in node.names:
                    full = f"{target}.{alias.name}"
                    yield (full if full in MODULES else target, alias.name, node.lineno, local)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("glintlab"):
                    yield (alias.name, alias.name, node.lineno, local)


def layer_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in LAYERS else None


def test_modules_are_found():
    assert {"glintlab.api.laws", "glintlab.validation.sweep", "glintlab.report.sections",
            "glintlab.cli.main"} <= set(MODULES)


def test_no_module_imports_the_package_init():
    bad = []
    for path in PACKAGE.rglob("*.py"):
        if path == PACKAGE / "__init__.py":
            continue
        for target, name, line, _ in imports_of(path):
            if target == "glintlab" and f"glintlab.{name}" not in MODULES:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line} imports {name} from glintlab/__init__")
    assert not bad, "\n".join(bad)


def test_layers_import_only_layers_below():
    bad = []
    for path in PACKAGE.rglob("*.py"):
        mine = layer_of(module_name(path))
        if mine is None:
            continue
        for target, _, line, _ in imports_of(path):
            theirs = layer_of(target)
            if theirs is not None and LAYERS.index(theirs) > LAYERS.index(mine):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: layer {mine} imports {target}")
    assert not bad, "\n".join(bad)


def test_no_function_hides_an_import_of_glintlab():
    bad = [f"{p.relative_to(PACKAGE.parent)}:{line} imports {target} inside a function"
           for p in PACKAGE.rglob("*.py") for target, _, line, local in imports_of(p) if local]
    assert not bad, "\n".join(bad)


def test_no_import_cycles():
    graph = {m: set() for m in MODULES}
    for path in PACKAGE.rglob("*.py"):
        me = module_name(path)
        for target, _, _, _ in imports_of(path):
            if target in graph and target != me and target != "glintlab":
                graph[me].add(target)
    state, stack = {}, []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for t in sorted(graph[m]):
            if state.get(t) == "open":
                cycle = stack[stack.index(t):] + [t]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if t not in state:
                visit(t)
        stack.pop()
        state[m] = "done"

    for m in MODULES:
        if m not in state:
            visit(m)


@pytest.mark.parametrize("order_seed", [1, 2, 3])
def test_every_module_imports_in_a_fresh_interpreter_in_random_order(order_seed):
    order = [m for m in MODULES]
    random.Random(order_seed).shuffle(order)
    code = "import importlib\nfor m in %r:\n    importlib.import_module(m)\n" % order
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, f"import order {order}:\n{run.stderr[-3000:]}"


def test_the_architecture_page_names_every_module():
    """docs/architecture.md's table of the package names each module of the api, validation, report and cli
    layers, and nothing else (a module added without its room on the page, or a name left after its
    module went, fails); the studies are named by example and must exist."""
    text = (PACKAGE.parents[1] / "docs" / "architecture.md").read_text()
    section = text[text.index("## The Python package"):text.index("\n## ", text.index("## The Python package") + 1)]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| `glintlab.") and len(cells) > 1:
            rows[cells[0].strip("`").split(".", 1)[1]] = set(re.findall(r"`(\w+)`", cells[1]))
    assert {"api", "validation", "studies", "report", "cli"} <= set(rows)
    for layer, named in rows.items():
        files = {p.stem for p in (PACKAGE / layer).glob("*.py") if p.stem != "__init__"}
        if layer == "studies":
            assert named <= files, sorted(named - files)
        else:
            assert named == files, (layer, "not on the page:", sorted(files - named), "not modules:", sorted(named - files))
