"""glintlab's PEP 517 / PEP 660 build backend: CMake builds ``glintlab._core``, the standard library writes the wheel.

Why a backend of our own (pyproject.toml says the same): Debian 12 has no scikit-build(-core), the usual
backend for a CMake project, and its meson-python (python3-mesonpy) builds Meson projects, not CMake ones;
PyPI is out of reach here, and pip's default build isolation installs ``build-system.requires`` from the
index, so any requirement at all (even setuptools, which Debian has) fails offline. This module needs
nothing beyond the standard library (``requires = []``, found through ``backend-path``), so
``pip install .`` works with or without isolation and with --no-index.

What it does: read the ``[project]`` table of pyproject.toml and the version from the top-level
CMakeLists.txt (``project(glintlab VERSION x.y.z)``); configure with -DGLINTLAB_PYTHON=ON and
-DGLINTLAB_PYTHON_EXE=<the installing interpreter> in build-wheel/<wheel tag>/ (kept, so a second install
only rebuilds what changed); build the ``_core`` target only; zip python/glintlab (*.py and data/**) with
the fresh _core*.so and a dist-info (METADATA, WHEEL, entry_points.txt, RECORD). ``build_editable``
builds _core into python/glintlab/ (where ``make build`` puts it) and installs a .pth to python/.
"""
from __future__ import annotations

import base64
import fcntl
import hashlib
import io
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # the source tree (pip builds in place)
PACKAGE = ROOT / "python" / "glintlab"


def _project() -> dict:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    cmake = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\s*\(\s*glintlab\s+VERSION\s+([0-9][0-9.]*)", cmake)
    if not match:
        raise RuntimeError("glintlab_build: no `project(glintlab VERSION x.y.z)` in CMakeLists.txt")
    return {**project, "version": match.group(1)}


def _tag() -> str:
    """The wheel tag of this interpreter, e.g. cp311-cp311-linux_x86_64 (the rules of `packaging.tags`)."""
    version = f"{sys.version_info.major}{sys.version_info.minor}"
    if sys.implementation.name == "cpython":
        interpreter = abi = f"cp{version}"
        abi += "d" if sysconfig.get_config_var("Py_DEBUG") else ""
        abi += "t" if sysconfig.get_config_var("Py_GIL_DISABLED") else ""
    else:  # e.g. PyPy: pp39-pypy39_pp73
        interpreter = f"pp{version}" if sys.implementation.name == "pypy" else f"{sys.implementation.name}{version}"
        abi = "_".join(sysconfig.get_config_var("SOABI").split("-")[:2]).replace(".", "_")
    return f"{interpreter}-{abi}-{sysconfig.get_platform().replace('-', '_').replace('.', '_')}"


def _dist_info(p: dict) -> str:
    return f"{p['name']}-{p['version']}.dist-info"


def _metadata_files(p: dict, tag: str) -> dict[str, bytes]:
    lines = ["Metadata-Version: 2.1", f"Name: {p['name']}", f"Version: {p['version']}",
             f"Summary: {p.get('description', '')}", f"Requires-Python: {p.get('requires-python', '>=3')}"]
    lines += [f"Requires-Dist: {req}" for req in p.get("dependencies", [])]
    for extra, reqs in p.get("optional-dependencies", {}).items():
        lines += [f"Provides-Extra: {extra}"] + [f'Requires-Dist: {req} ; extra == "{extra}"' for req in reqs]
    readme = ""
    if p.get("readme") and (ROOT / p["readme"]).is_file():
        lines.append("Description-Content-Type: text/markdown")
        readme = "\n" + (ROOT / p["readme"]).read_text(encoding="utf-8")
    scripts = "".join(f"{name} = {target}\n" for name, target in p.get("scripts", {}).items())
    wheel = f"Wheel-Version: 1.0\nGenerator: glintlab_build\nRoot-Is-Purelib: false\nTag: {tag}\n"
    return {"METADATA": ("\n".join(lines) + "\n" + readme).encode(), "WHEEL": wheel.encode(),
            "entry_points.txt": f"[console_scripts]\n{scripts}".encode(), "top_level.txt": b"glintlab\n"}


def _build_dir(tag: str) -> Path:
    return ROOT / "build-wheel" / tag  # one CMake tree per interpreter ABI, shared by every venv of it


def _cmake_core(module_dir: Path, tag: str) -> None:
    """Configure (each time: cheap, and picks up a different interpreter) and build the _core target."""
    build = _build_dir(tag)
    build.mkdir(parents=True, exist_ok=True)
    jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
    # One build at a time per build tree (two concurrent `pip install .` would race in the same tree).
    with open(build / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        for cmd in (["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                     "-DGLINTLAB_PYTHON=ON", "-DGLINTLAB_TESTS=OFF", f"-DGLINTLAB_PYTHON_EXE={sys.executable}",
                     f"-DGLINTLAB_PYTHON_MODULE_DIR={module_dir}"],
                    ["cmake", "--build", str(build), "--target", "_core", "-j", jobs]):
            print("glintlab_build:", " ".join(cmd), file=sys.stderr, flush=True)
            try:
                subprocess.run(cmd, check=True, stdout=sys.stderr)  # pip shows it on failure or with -v
            except FileNotFoundError:
                raise RuntimeError("glintlab_build: no `cmake`; install the Debian build packages "
                                   "(scripts/install-deps.sh, README.md: Install)") from None


def _write_wheel(wheel_directory: str, p: dict, tag: str, files: dict[str, bytes]) -> str:
    """Zip `files` (archive path -> bytes) with the dist-info and its RECORD; return the wheel's file name."""
    dist_info = _dist_info(p)
    files = {**files, **{f"{dist_info}/{name}": data for name, data in _metadata_files(p, tag).items()}}
    record = []
    for path, data in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.append(f"{path},sha256={digest},{len(data)}")
    record.append(f"{dist_info}/RECORD,,")
    files[f"{dist_info}/RECORD"] = ("\n".join(record) + "\n").encode()
    name = f"{p['name']}-{p['version']}-{tag}.whl"
    with zipfile.ZipFile(Path(wheel_directory) / name, "w", zipfile.ZIP_DEFLATED) as whl:
        for path, data in files.items():
            info = zipfile.ZipInfo(path, date_time=(2020, 1, 1, 0, 0, 0))  # reproducible
            is_exec = path.endswith(".so")
            info.external_attr = (0o755 if is_exec else 0o644) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            whl.writestr(info, data)
    return name


def _package_files() -> list[Path]:
    """What goes into the wheel from python/glintlab: the modules and data/**, not caches or a stale _core."""
    keep = [f for f in PACKAGE.rglob("*.py")] + [f for f in (PACKAGE / "data").rglob("*") if f.is_file()]
    return sorted(f for f in set(keep) if "__pycache__" not in f.parts and f.suffix not in (".pyc", ".so"))


# ---- PEP 517 hooks ----------------------------------------------------------------------------------------

def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def get_requires_for_build_editable(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    p = _project()
    target = Path(metadata_directory) / _dist_info(p)
    target.mkdir(parents=True, exist_ok=True)
    for name, data in _metadata_files(p, _tag()).items():
        (target / name).write_bytes(data)
    return target.name


prepare_metadata_for_build_editable = prepare_metadata_for_build_wheel


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    p, tag = _project(), _tag()
    module_dir = _build_dir(tag) / "python"  # the .so only; python/glintlab/ is left alone
    _cmake_core(module_dir, tag)
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    core = module_dir / f"_core{suffix}"
    if not core.is_file():
        raise RuntimeError(f"glintlab_build: the build did not produce {core}")
    files = {f"glintlab/{f.relative_to(PACKAGE).as_posix()}": f.read_bytes() for f in _package_files()}
    files[f"glintlab/_core{suffix}"] = core.read_bytes()
    return _write_wheel(wheel_directory, p, tag, files)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    """PEP 660: _core is built into python/glintlab/ and a .pth puts python/ on sys.path (edits show at once)."""
    p, tag = _project(), _tag()
    _cmake_core(PACKAGE, tag)
    return _write_wheel(wheel_directory, p, tag, {"glintlab_editable.pth": f"{ROOT / 'python'}\n".encode()})


SDIST_DIRS = ("backend", "bench", "bindings", "cmake", "core", "python", "tests", "validation")


def build_sdist(sdist_directory, config_settings=None):
    """The sources CMake needs (tests/ and bench/ too: the top-level CMakeLists.txt adds them) and PKG-INFO."""
    p = _project()
    base = f"{p['name']}-{p['version']}"
    name = f"{base}.tar.gz"
    skip = ("__pycache__", ".ipynb_checkpoints")
    files = [ROOT / f for f in ("pyproject.toml", "CMakeLists.txt", "README.md")]
    for top in SDIST_DIRS:
        files += [f for f in (ROOT / top).rglob("*") if f.is_file() and not set(f.parts) & set(skip)
                  and f.suffix not in (".pyc", ".so")]
    with tarfile.open(Path(sdist_directory) / name, "w:gz", format=tarfile.PAX_FORMAT) as tar:
        for f in sorted(files):
            tar.add(f, arcname=f"{base}/{f.relative_to(ROOT).as_posix()}", recursive=False)
        pkg_info = _metadata_files(p, "")["METADATA"]
        info = tarfile.TarInfo(f"{base}/PKG-INFO")
        info.size, info.mode = len(pkg_info), 0o644
        tar.addfile(info, io.BytesIO(pkg_info))
    return name


__all__ = ["build_wheel", "build_sdist", "build_editable", "get_requires_for_build_wheel",
           "get_requires_for_build_sdist", "get_requires_for_build_editable",
           "prepare_metadata_for_build_wheel", "prepare_metadata_for_build_editable"]
