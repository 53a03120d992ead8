"""What the `glintlab` subcommands share: the options several of them take (each defined once here),
the argument types of their flags, and the few runtime helpers (plugins, tables on the terminal, the
experiment runner of ``run`` and ``sweep``).

A subcommand is one module of :mod:`glintlab.cli` with ``add_parser(subparsers)`` (its flags, through
the helpers below where an option is shared) and ``run(args) -> int`` (its exit status: 0 success, 1 a
failed check, 2 bad input); :mod:`glintlab.cli.main` assembles them.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd

from ..api.plugins import load_plugin
from ..api.shader_resources import read_image
from ..studies.experiment_plots import run_experiment
from ..api import checks as V


# ---------------------------------------------------------------- argument types

def _int_or_float(text: str) -> int | float:
    """``text`` as an int when it is one (exact beyond 2^53), else as a float; NaN when it is neither."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return math.nan


def count_arg(text: str) -> int:
    """A count flag (--samples 1e6, 100000, 2.5e5): an integer, or a float in any notation whose value
    is a whole number (as the help texts write the defaults)."""
    value = _int_or_float(text)
    if isinstance(value, int):
        return value
    if not (math.isfinite(value) and value == int(value)):
        raise argparse.ArgumentTypeError(f"{text!r} is invalid; expected a whole number (1000000 or 1e6)")
    return int(value)


def axis_arg(values, flag):
    """--n 16 1000 | --n logspace:0:6:13 | --n linspace:0:1:5 | --n standard"""
    if values is None:
        return "standard"
    if len(values) == 1 and values[0] == "standard":
        return "standard"
    if len(values) == 1 and ":" in values[0]:
        kind, *rest = values[0].split(":")
        if kind not in ("logspace", "linspace") or len(rest) != 3:
            V.fail(flag, values[0], "numbers, 'standard', 'logspace:LO:HI:COUNT' or 'linspace:LO:HI:COUNT'")
        try:
            lo, hi, count = float(rest[0]), float(rest[1]), int(rest[2])
        except ValueError:
            V.fail(flag, values[0], "LO and HI numbers and an integer COUNT")
        if not (math.isfinite(lo) and math.isfinite(hi)):
            V.fail(flag, values[0], "finite LO and HI")
        return {kind: [lo, hi, count]}
    try:
        numbers = [float(x) for x in values]
    except ValueError:
        V.fail(flag, " ".join(values), "numbers")
    # Checked here: a NaN would otherwise be reported against the JSON document the flags become.
    for text, x in zip(values, numbers):
        if not math.isfinite(x):
            V.fail(flag, text, "finite numbers")
    return numbers


def law_arg(text):
    """name, name:key=value,key=value (built-in parameters), or a Python law FILE.py:FUNCTION
    [:n_uniforms=K,binning=round] (gl.custom_law of that function, named after it)."""
    head, dot_py, tail = text.partition(".py:")
    if dot_py:
        function, _, options = tail.partition(":")
        if not function:
            raise ValueError(f"--laws {text!r} is invalid; expected FILE.py:FUNCTION[:n_uniforms=K,binning=round]")
        spec = {"name": function, "python": f"{head}.py:{function}"}
        for item in filter(None, options.split(",")):
            key, eq, value = item.partition("=")
            if not eq or key not in ("n_uniforms", "binning", "name"):
                raise ValueError(f"--laws {text!r} is invalid; expected options n_uniforms=K, binning=none|round, "
                                 f"name=NAME after FILE.py:FUNCTION")
            if key == "n_uniforms":
                try:
                    value = int(value)
                except ValueError:
                    raise ValueError(f"--laws {text!r} is invalid; n_uniforms = {value!r}, expected an integer") from None
            spec[key] = value
        return spec
    name, _, rest = text.partition(":")
    if not rest:
        return name
    params = {}
    for item in rest.split(","):
        key, eq, value = item.partition("=")
        if not eq:
            raise ValueError(f"--laws {text!r} is invalid; expected NAME or NAME:KEY=VALUE,...")
        try:
            params[key] = float(value)
        except ValueError:
            params[key] = value
    return {"name": name, "params": params}


# ---------------------------------------------------------------- shared options (each defined once)

def add_seed(p, default=1, help=None):
    """--seed: every command that draws takes one (an int; default 1, or None where the command has
    its own default)."""
    p.add_argument("--seed", type=int, default=default, help=help)


def add_samples(p, help, default=None):
    """--samples: draws per point, a count (1e6 accepted)."""
    add_count(p, "--samples", help, default)


def add_count(p, flag, help, default=None):
    """A count flag (``count_arg``: 1e6 or 1000000)."""
    p.add_argument(flag, type=count_arg, default=default, help=help)


def add_quick(p, help):
    p.add_argument("--quick", action="store_true", help=help)


def add_quiet(p):
    p.add_argument("--quiet", action="store_true", help="no tables on stdout, no progress bar")


def add_plugins(p, help="load a C++ plugin's laws first (repeatable)"):
    p.add_argument("--plugin", action="append", metavar="LIB.so", help=help)


def add_laws(p, help):
    p.add_argument("--laws", nargs="+", help=help)


def add_scenes(p):
    p.add_argument("scenes", nargs="+", metavar="SCENE.json", help="scene files (e.g. data/scenes/*.json)")


def add_scale(p, default, help):
    p.add_argument("--scale", type=float, default=default, help=help)


def add_costs(p, help):
    p.add_argument("--costs", metavar="COSTS.csv", help=help)


def add_outputs(p, out_default=None, plugins=True, store=False, out_help=None):
    """--out, --quiet, (``plugins``) --plugin and (``store``) the resumable store and the Dask engine."""
    if store:
        p.add_argument("--store", help="resumable store (JSON lines): finished rows are kept across interruptions")
        p.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on the Dask scheduler at ADDRESS (tcp://host:8786); same table as a local run")
        p.add_argument("--workers", type=int, metavar="K",
                       help="run on a Dask LocalCluster of K worker processes on this machine")
        p.add_argument("--timeout", type=float, default=10.0,
                       help="seconds to wait for the scheduler to answer (default: 10)")
    p.add_argument("--out", default=out_default, help=f"output directory (default: {out_help or out_default})")
    add_quiet(p)
    if plugins:
        add_plugins(p)


def add_shader_options(p):
    """The options of every command that compiles the user's shader code (``shader``, ``sampler``,
    ``images``; read back by :func:`shader_options`): include folders, defines and the Vulkan device."""
    p.add_argument("-I", "--include-dir", "--include", dest="include_dirs", action="append", default=[],
                   metavar="DIR", help="a folder searched for the shader's #include files (repeatable)")
    p.add_argument("-D", "--define", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                   help="a define passed to the compiler, -D NAME=VALUE (NAME alone: 1; repeatable)")
    p.add_argument("--device", default="auto",
                   help="the Vulkan device: auto (default: a GPU if any, else lavapipe), gpu, cpu, an index or a name")


def shader_options(args) -> dict:
    """``add_shader_options``'s flags as the keywords of gl.shader_law, gl.shader_sampler and
    gl.shader_method: ``defines`` ({NAME: VALUE}; a later -D of a name wins), ``include_dirs``,
    ``device``. A define without a name is bad input naming it."""
    defines = {}
    for item in args.defines:
        key, sep, value = item.partition("=")
        if not key.strip().isidentifier():
            V.fail("--define", item, "NAME=VALUE with NAME a macro name (e.g. -D ALPHA=0.5)")
        defines[key.strip()] = value if sep else "1"
    return {"defines": defines, "include_dirs": list(args.include_dirs), "device": args.device}


def given_shader_options(args) -> dict:
    """The shader options given on the command line, {flag: value} (for a command to refuse them where
    no shader takes them)."""
    given = {"--define": args.defines, "--include-dir": args.include_dirs,
             "--device": args.device if args.device != "auto" else None}
    return {flag: value for flag, value in given.items() if value}


# ---------------------------------------------------------------- runtime helpers

def add_resource_options(p):
    """--texture NAME=FILE and --uniform NAME=VALUE: the data of the read-only resources a shader
    declares (``shader``, ``sampler``, ``images``; docs/guide/shaders.md#textures-buffers-and-uniforms)."""
    p.add_argument("--texture", action="append", default=[], metavar="NAME=FILE",
                   help="bind an image file (PNG, OpenEXR, or a .npy array: 3D textures, tables) to the texture "
                        "NAME the shader declares (repeatable; a storage buffer NAME takes a .npy file too)")
    p.add_argument("--uniform", action="append", default=[], metavar="NAME=VALUE",
                   help="a uniform / cbuffer member by name: a number or comma-separated numbers (repeatable; "
                        "floats are rounded to the nearest float32)")


def _number(flag, item, text):
    value = _int_or_float(text)
    if not math.isfinite(value):
        V.fail(flag, item, "NAME=VALUE with finite numbers (VALUE: 0.5, 3, or 1,0.5,0.25)")
    return value


def given_resource_options(args) -> dict:
    """--texture and --uniform as given, {flag: values} (for a command to refuse them where no shader takes
    them)."""
    given = {"--texture": getattr(args, "texture", []), "--uniform": getattr(args, "uniform", [])}
    return {flag: value for flag, value in given.items() if value}


def resource_options(args) -> dict:
    """The keywords (``textures``, ``buffers``, ``uniforms``) of --texture and --uniform: each file read
    here (a missing or unreadable one is bad input naming it); a .npy file whose NAME the shader declares
    as a storage buffer is bound as one (the shader decides, once compiled: both dicts carry it)."""
    textures, uniforms = {}, {}
    for item in getattr(args, "texture", []):
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            V.fail("--texture", item, "NAME=FILE")
        textures[name] = read_image(Path(path))
    for item in getattr(args, "uniform", []):
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            V.fail("--uniform", item, "NAME=VALUE")
        numbers = [_number("--uniform", item, x.strip()) for x in value.split(",")]
        uniforms[name] = numbers[0] if len(numbers) == 1 else numbers
    return {"textures": textures, "uniforms": uniforms}


def load_plugins(paths):
    for path in paths or []:
        load_plugin(path)


def print_table(df, quiet, max_rows=60):
    if quiet:
        return
    with pd.option_context("display.width", 200, "display.max_columns", 30, "display.max_rows", max_rows):
        print(df.to_string(index=False, float_format=lambda x: f"{x:.4g}", max_rows=max_rows))


def run_experiment_cmd(source, args) -> int:
    """``run`` and ``sweep``: the experiment document ``source`` on the engine the flags name."""
    load_plugins(args.plugin)
    out = Path(args.out) if args.out else None
    engine = {}
    if args.scheduler is not None or args.workers is not None:
        engine = dict(engine="dask", scheduler=args.scheduler, workers=args.workers, timeout=args.timeout)
    result = run_experiment(source, out=out, store=args.store, progress=None if not args.quiet else False, **engine)
    name = result.config["name"]
    if not args.quiet:
        print_table(result.table, args.quiet)
        where = f"; wrote {', '.join(str(f) for f in result.files)}" if result.files else ""
        print(f"\n{name}: {len(result.table)} rows in {result.seconds} s{where}")
    return 0


def scene_costs(path):
    """--costs of ``profile`` and ``advise``: the law costs table; None (not given) for the costs recorded
    with the package, "measure" to time the laws in this process."""
    if path is None or path == "measure":
        return path
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        V.fail("--costs", path, f"a CSV with columns law, ns_per_eval [, ns_per_trial] ({exc})")
    if not {"law", "ns_per_eval"} <= set(table.columns):
        V.fail("--costs", path, "columns law, ns_per_eval [, ns_per_trial]")
    return table[[c for c in ("law", "ns_per_eval", "ns_per_trial") if c in table]].drop_duplicates("law")
