"""`pip install .` (pyproject.toml, backend/glintlab_build.py): a fresh venv over Debian's interpreter gets the
compiled core, the package data and the `glintlab` command, and uses them from outside the source tree.

Slow (marker `install`; deselect with -m "not install"): pip runs CMake, and the first run compiles the C++
core into build-wheel/ (~2.5 min of CPU on 2 cores); later runs rebuild incrementally (~30 s in all). The
venv is made with --system-site-packages (numpy, scipy, ... are Debian's) and pip gets --no-index, so
nothing is downloaded and any attempt to would fail.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's, with numpy; not the `python3` first on some PATHs
INSTALL_TIMEOUT = 1200  # s: a cold build on a loaded 2-core machine

pytestmark = pytest.mark.install


def _run(cmd, cwd, timeout, env):
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, timeout=timeout,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"timed out after {timeout} s: {' '.join(map(str, cmd))}\n{(exc.output or '')[-4000:]}")
    seconds = time.perf_counter() - t0
    print(f"[install] {seconds:6.1f} s  rc {proc.returncode}  {' '.join(map(str, cmd))}", file=sys.stderr)
    return proc


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A fresh --system-site-packages venv with glintlab pip-installed from this tree; (venv dir, env, work dir)."""
    if not Path(SYSTEM_PYTHON).exists():
        pytest.skip(f"{SYSTEM_PYTHON} (Debian's interpreter) is missing")
    base = tmp_path_factory.mktemp("install")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV") and not k.startswith("PIP_")}
    env["PATH"] = f"{base / 'venv' / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    work = base / "work"  # every command runs here, outside the source tree
    work.mkdir()
    proc = _run([SYSTEM_PYTHON, "-m", "venv", "--system-site-packages", base / "venv"], work, 300, env)
    assert proc.returncode == 0, proc.stdout
    proc = _run([base / "venv" / "bin" / "python", "-m", "pip", "install", "--no-index", ROOT],
                work, INSTALL_TIMEOUT, env)
    assert proc.returncode == 0, f"pip install failed:\n{proc.stdout[-8000:]}"
    return base / "venv", env, work


def test_installed_copy_is_imported(venv):
    root, env, work = venv
    code = ("import glintlab, sys; assert 'site-packages' in glintlab.__file__, glintlab.__file__; "
            "print(glintlab.__file__); print(glintlab.law('gated').sample(16, .1, size=5, seed=1))")
    proc = _run([root / "bin" / "python", "-c", code], work, 120, env)
    assert proc.returncode == 0, proc.stdout
    path = Path(proc.stdout.splitlines()[0])
    assert ROOT not in path.parents and (path.parent / "data" / "bounds" / "default.json").is_file()
    assert any(p.name.startswith("_core.") and p.suffix == ".so" for p in path.parent.iterdir())


def test_console_script_check_uses_shipped_bounds(venv):
    root, env, work = venv
    proc = _run([root / "bin" / "glintlab", "check"], work, 600, env)
    assert proc.returncode == 0, proc.stdout[-8000:]


def test_console_script_report(venv):
    root, env, work = venv
    out = work / "r"
    proc = _run([root / "bin" / "glintlab", "report", "--quick", "--only", "exact_laws", "--out", out],
                work, 600, env)
    assert proc.returncode == 0, proc.stdout[-8000:]
    assert (out / "index.html").is_file()
