"""The `glintlab` command line. Exit status: 0 success, 1 a check failed, 2 bad input.

Subcommands: laws, run (one experiment), sweep (an experiment from flags), check (error bounds),
bench (speed against accuracy), extremes (numerical extremes of every law), aniso (anisotropic grids
against the ground truth), profile and advise (scenes), images (glint images of scenes and their
flicker), shader (a shader's counting function run on Vulkan: verdict and report), sampler (a direction
sampler against its pdf), report (the main job).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from .._core import __version__
from ..api.laws import law_summaries, parse_law_label
from ..api.plugins import load_plugin
from ..api.shaders import ShaderOutputError, emit_shader, shader_law
from ..report.config import load_config as load_report_config
from ..report.html import write_extremes_report
from ..report.runner import print_summary as print_report_summary
from ..report.runner import run as run_report
from ..report.sections import SECTIONS
from ..resources import data_path
from ..studies.aniso import write_report as write_aniso_report
from ..studies.scene_images import write_images
from ..api.method_shaders import shader_method
from ..validation.scene_images import Material, frame_inputs, make_method, with_directional_light
from ..studies.scenes import write_profiles
from ..studies.shaders import write_verdict
from ..studies.speed_accuracy import write_bench
from ..validation.advisor import advice_table, advise
from ..validation.bench import speed_accuracy
from ..validation.bounds import check, format_table, write_junit
from ..validation.experiment import run_experiment
from ..validation.extremes import extremes_summary, extremes_table, invalid_inputs_table
from ..validation.profile import profile_scene
from ..validation.references import resolve_law
from ..validation.scene import load_scene
from ..validation.shader_check import shader_verdict
from ..api.samplers import WRONG_KINDS, load_sampler, wrong_sampler
from ..validation.sampler_test import sampler_test


def _cmd_laws(args) -> int:
    for name, summary in law_summaries().items():
        print(f"{name:12s} {summary}")
    return 0


def _cmd_report(args) -> int:
    if args.list:
        doc, source = load_report_config(args.config)
        for entry in doc["sections"]:
            sec = SECTIONS.get(entry["name"])
            print(f"{sec.name:20s} {sec.title}")
        return 0
    summary = run_report(Path(args.out), quick=args.quick, seed=args.seed, quiet=args.quiet, only=args.only,
                         config=args.config)
    if not args.quiet:
        print_report_summary(summary)
        print(f"\nwrote {args.out}/index.html, report.json, *.csv, *.png in {summary['seconds']} s")
    for failure in summary["failures"]:
        print(f"glintlab report: FAILED {failure}", file=sys.stderr)
    return 1 if summary["failures"] else 0


def _load_plugins(paths):
    for path in paths or []:
        load_plugin(path)


def _print_table(df, quiet, max_rows=60):
    if quiet:
        return
    with pd.option_context("display.width", 200, "display.max_columns", 30, "display.max_rows", max_rows):
        print(df.to_string(index=False, float_format=lambda x: f"{x:.4g}", max_rows=max_rows))


def _run_experiment(source, args) -> int:
    _load_plugins(args.plugin)
    out = Path(args.out) if args.out else None
    engine = {}
    if args.scheduler is not None or args.workers is not None:
        engine = dict(engine="dask", scheduler=args.scheduler, workers=args.workers, timeout=args.timeout)
    result = run_experiment(source, out=out, store=args.store, progress=None if not args.quiet else False, **engine)
    name = result.config["name"]
    if not args.quiet:
        _print_table(result.table, args.quiet)
        where = f"; wrote {', '.join(str(f) for f in result.files)}" if result.files else ""
        print(f"\n{name}: {len(result.table)} rows in {result.seconds} s{where}")
    return 0


def _cmd_run(args) -> int:
    return _run_experiment(args.experiment, args)


def _axis_arg(values, flag):
    """--n 16 1000 | --n logspace:0:6:13 | --n linspace:0:1:5 | --n standard"""
    if values is None:
        return "standard"
    if len(values) == 1 and values[0] == "standard":
        return "standard"
    if len(values) == 1 and ":" in values[0]:
        kind, *rest = values[0].split(":")
        if kind not in ("logspace", "linspace") or len(rest) != 3:
            raise ValueError(f"{flag} = {values[0]!r} is invalid; expected numbers, 'standard', "
                             "'logspace:LO:HI:COUNT' or 'linspace:LO:HI:COUNT'")
        try:
            lo, hi, count = float(rest[0]), float(rest[1]), int(rest[2])
        except ValueError:
            raise ValueError(f"{flag} = {values[0]!r} is invalid; expected LO and HI numbers and an integer COUNT") from None
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ValueError(f"{flag} = {values[0]!r} is invalid; expected finite LO and HI")
        return {kind: [lo, hi, count]}
    try:
        numbers = [float(x) for x in values]
    except ValueError:
        raise ValueError(f"{flag} = {' '.join(values)!r} is invalid; expected numbers") from None
    # Checked here: a NaN would otherwise be reported against the JSON document the flags become.
    for text, x in zip(values, numbers):
        if not math.isfinite(x):
            raise ValueError(f"{flag} = {text!r} is invalid; expected finite numbers")
    return numbers


def _law_arg(text):
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


def _cmd_sweep(args) -> int:
    doc = {"name": args.name, "laws": [_law_arg(x) for x in args.laws],
           "grid": {"n": _axis_arg(args.n, "--n"), "p": _axis_arg(args.p, "--p")},
           "metrics": args.metrics, "reference": _law_arg(args.reference) if args.reference else "binomial",
           "samples": args.samples, "seed": args.seed}
    if isinstance(doc["reference"], dict):
        doc["reference"] = {"law": doc["reference"]}
    return _run_experiment(json.dumps(doc), args)


def _default_outputs(args):
    """The output folders that depend on other arguments (run: the file's stem; sweep: --name)."""
    if args.command == "run" and args.out is None:
        args.out = "out/experiments/" + Path(args.experiment).stem
    if args.command == "sweep":
        # The name becomes a folder under out/sweeps: a path (../../x) would write elsewhere.
        if not args.name or args.name in (".", "..") or any(c in args.name for c in "/\\\0"):
            raise ValueError(f"--name = {args.name!r} is invalid; expected a plain name without '/' (it names "
                             "the output folder out/sweeps/NAME)")
        if args.out is None:
            args.out = "out/sweeps/" + args.name


def _prepare_outputs(args):
    """Checks, before any work, that the output folder (and the files of --store and --junit) can be
    created and written, so that a result is never computed and then lost to a bad path. Nothing is
    created here: a command that fails on its input leaves no empty folder behind."""
    if getattr(args, "list", False):  # report --list writes nothing
        return
    targets = []
    if getattr(args, "out", None):
        targets.append(("--out", Path(args.out), True))
    for flag in ("store", "junit"):
        if getattr(args, flag, None):
            targets.append((f"--{flag}", Path(getattr(args, flag)), False))
    for flag, path, is_folder in targets:
        if path.exists():
            if is_folder and not path.is_dir():
                raise ValueError(f"{flag} = {str(path)!r} is invalid; it is a file, expected a folder")
            if not is_folder and path.is_dir():
                raise ValueError(f"{flag} = {str(path)!r} is invalid; it is a folder, expected a file")
            if not os.access(path, os.W_OK):
                raise ValueError(f"{flag} = {str(path)!r} is invalid; it cannot be written")
            continue
        # The nearest existing ancestor must be a folder we can create entries in.
        parent = path.absolute().parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise ValueError(f"{flag} = {str(path)!r} is invalid; {str(parent)!r} is a file, expected a folder")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise ValueError(f"{flag} = {str(path)!r} is invalid; the folder {str(parent)!r} is not writable")


def _one_line(exc: BaseException) -> str:
    """An exception as the one line the CLI prints (never a traceback)."""
    if isinstance(exc, SyntaxError):  # a Python law file (--laws FILE.py:fn) that does not parse
        return f"{exc.filename}:{exc.lineno}: {exc.msg}"
    if isinstance(exc, RecursionError):
        return "the input is nested too deeply to be read (a JSON document nested thousands of levels deep?)"
    if isinstance(exc, MemoryError):
        detail = f" ({exc})" if str(exc) else ""
        return f"out of memory{detail}; expected sizes that fit in this machine's memory (lower --samples?)"
    if isinstance(exc, OSError):
        where = exc.filename if exc.filename is not None else ""
        return f"{where}: {exc.strerror or exc}" if where else str(exc.strerror or exc)
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


def _cmd_check(args) -> int:
    _load_plugins(args.plugin)
    table = check(args.bounds, progress=None if not args.quiet else False)
    if args.junit:
        write_junit(table, args.junit)
    bad = table[~table.ok]
    if not args.quiet:
        print(format_table(table))
        print(f"\n{len(table) - len(bad)} of {len(table)} bounds hold ({args.bounds})")
    for r in bad.itertuples():
        rel = "<=" if r.limit == "max" else ">="
        print(f"glintlab check: VIOLATED {r.id}: {r.metric} = {r.worst:.6g} at n = {r.at_n:g}, p = {r.at_p:g} "
              f"(bound {rel} {r.bound:.6g})", file=sys.stderr)
    return 1 if len(bad) else 0


def _cmd_bench(args) -> int:
    _load_plugins(args.plugin)
    laws = [_law_arg(x) for x in args.laws] if args.laws else None
    summary, errors = speed_accuracy(laws, samples=args.samples, seed=args.seed, repeats=args.repeats,
                                     progress=None if not args.quiet else False)
    files = write_bench(args.out, summary, errors)
    if not args.quiet:
        _print_table(summary[["law", "accuracy", "tv_max", "tv_median", "mean_rel_err_max", "ns_per_sample",
                              "speedup_vs_numpy", "ns_ratio_1e9_vs_16", "pareto"]], args.quiet)
        print(f"\nnumpy binomial: {summary.numpy_ns.iloc[0]:.1f} ns/sample (mean of the timing points); "
              f"wrote {', '.join(str(f) for f in files)}")
    return 0


def _cmd_extremes(args) -> int:
    _load_plugins(args.plugin)
    laws = [_law_arg(x) for x in args.laws] if args.laws else None
    if laws is not None:
        laws = [resolve_law(x) for x in laws]
    table = extremes_table(laws, samples=args.samples, seed=args.seed)
    invalid = invalid_inputs_table(laws)
    summary = extremes_summary(table)
    path = write_extremes_report(args.out, table, invalid, summary)
    failures = int((~table.ok).sum()) + int((~invalid.ok).sum())
    if not args.quiet:
        _print_table(summary, args.quiet)
        print(f"\n{failures} failing rows; wrote {path}")
    return 1 if (failures and args.strict) else 0


def _count_arg(text: str) -> int:
    """A count flag (--samples 1e6, 100000, 2.5e5): an integer, or a float in any notation whose value
    is a whole number (as the help texts write the defaults)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value == int(value)):
        raise argparse.ArgumentTypeError(f"{text!r} is invalid; expected a whole number (1000000 or 1e6)")
    return int(value)


def _cmd_shader(args) -> int:
    _load_plugins(args.plugin)
    if args.emit:  # a shipped shader as one paste-ready file, nothing measured
        print(emit_shader(args.emit, args.lang or "hlsl"), end="")
        return 0
    if args.file is None:
        raise ValueError("FILE is missing; expected a shader file (or --emit NAME for a shipped shader)")
    for flag in ("samples", "grid_samples", "grid_stride", "rows", "speed_evaluations"):
        if getattr(args, flag) < 1:
            raise ValueError(f"--{flag.replace('_', '-')} = {getattr(args, flag)} is invalid; expected an integer >= 1")
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        raise ValueError(f"--timeout = {args.timeout} is invalid; expected seconds > 0")
    defines = {}
    for item in args.define:
        key, sep, value = item.partition("=")
        defines[key] = value if sep else "1"
    try:  # FILE is always a path, never code (a mistyped name is reported missing)
        law = shader_law(Path(args.file), entry=args.entry, language=args.lang, n_uniforms=args.uniforms,
                         defines=defines, include_dirs=args.include, device=args.device, timeout=args.timeout)
    except RuntimeError as exc:  # no Vulkan device: the environment, not the shader
        print(f"glintlab shader: {exc}", file=sys.stderr)
        return 2
    for name in [args.against] + ([args.twin] if args.twin else []):
        resolve_law(name)  # an unknown law is bad input (exit 2) before any measurement
    if not args.quiet:
        print(f"{args.file}: compiled ({law.language}, entry {law.entry}); device: {law.device}")
    verdict = shader_verdict(law, against=args.against, twin=args.twin, samples=args.samples,
                             grid_samples=args.grid_samples, grid_stride=args.grid_stride, seed=args.seed,
                             rows=args.rows, speed_evaluations=args.speed_evaluations)
    if args.bounds:
        try:
            table = check(args.bounds, substitute={args.against: law, law.name: law}, progress=False)
        except ShaderOutputError as exc:  # the shader's NaN or negative count: a failed check
            verdict["failures"].append(f"bounds: {exc}")
        else:
            verdict["tables"]["bounds"] = table
            verdict["failures"] += [f"bound {r.id}: {r.metric} = {r.worst:.6g} at n = {r.at_n:g}, p = {r.at_p:g} "
                                    f"(bound {r.bound:.6g})" for r in table[~table.ok].itertuples()]
    path = write_verdict(args.out, verdict, law, args.against, args.twin)
    if not args.quiet:
        _print_table(verdict["tables"]["points"], False)
        if "rows" in verdict["tables"]:
            _print_table(verdict["tables"]["rows"], False)
        _print_table(verdict["tables"]["speed"], False)
        print(f"\nwrote {path}")
    for failure in verdict["failures"]:
        print(f"glintlab shader: FAIL {failure}", file=sys.stderr)
    if verdict["caveat"]:
        print(f"glintlab shader: NOTE not what a GPU would compute: {verdict['caveat']}", file=sys.stderr)
    if not args.quiet:
        print("verdict: " + ("FAIL" if verdict["failures"] else f"pass (against {args.against})") +
              ("" if verdict["gpu_faithful"] else " (on lavapipe, not what a GPU would compute: see the note)"))
    return 1 if verdict["failures"] else 0


def _sampler_params(items):
    """--param k=v (repeatable): numbers, comma-separated tuples of numbers, or strings."""
    params = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--param = {item!r} is invalid; expected NAME=VALUE (e.g. alpha=0.3, wo=0.6,0,0.8)")
        parts = value.split(",")
        try:
            nums = [float(p) for p in parts]
            params[key] = tuple(nums) if len(nums) > 1 else (int(nums[0]) if parts[0].strip().lstrip("-").isdigit()
                                                             else nums[0])
        except ValueError:
            params[key] = value
    return params


def check_sampler(sampler, args) -> int:
    """Runs the harness on a sampler object with the command's options and prints the verdict: the exit
    status (0 pass, 1 fail). The hook for every kind of sampler (registered by name, shader files)."""
    bins = args.bins
    if bins != "adaptive":
        try:
            bins = tuple(int(x) for x in bins.lower().split("x"))
        except ValueError:
            raise ValueError(f"--bins = {args.bins!r} is invalid; expected 'adaptive' or a grid N1xN2 (e.g. 30x60)") from None
    res = sampler_test(sampler, samples=args.samples, seed=args.seed, bins=bins, significance=args.significance,
                       out=args.out, write="always" if args.write_always else "failure")
    if not args.quiet:
        print(repr(res))
        for path in res.files:
            print(f"wrote {path}")
    if not res.passed:
        print(f"glintlab sampler: FAIL {res.name}: p = {res.pvalue:.4g}" + (f" ({res.note})" if res.notes else ""),
              file=sys.stderr)
    elif not args.quiet:
        print(f"verdict: pass (p = {res.pvalue:.4g} >= {args.significance:g})")
    return 0 if res.passed else 1


def _cmd_sampler(args) -> int:
    if args.samples < 1:
        raise ValueError(f"--samples = {args.samples} is invalid; expected an integer >= 1")
    s = load_sampler(args.sampler, **_sampler_params(args.param))
    return check_sampler(wrong_sampler(s, args.wrong) if args.wrong else s, args)


def _cmd_aniso(args) -> int:
    paths, tables = write_aniso_report(args.out, full=args.full, samples=args.samples, seed=args.seed,
                                 image=not args.no_image)
    if not args.quiet:
        _print_table(tables["aniso_summary"], args.quiet)
        if "aniso_image" in tables:
            _print_table(tables["aniso_image"], args.quiet)
        print(f"\nwrote {', '.join(str(p) for p in paths)} and CSV tables in {args.out}")
    return 0


def _scene_costs(path):
    if path is None:
        return None
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"--costs = {path!r} is invalid; expected a CSV with columns law, ns_per_eval "
                         f"[, ns_per_trial] ({exc})") from None
    if not {"law", "ns_per_eval"} <= set(table.columns):
        raise ValueError(f"--costs = {path!r} is invalid; expected columns law, ns_per_eval [, ns_per_trial]")
    return table[[c for c in ("law", "ns_per_eval", "ns_per_trial") if c in table]].drop_duplicates("law")





def _cmd_profile(args) -> int:
    scenes = [load_scene(path) for path in args.scenes]  # all validated before any work
    costs = _scene_costs(args.costs)
    laws = None if costs is None else [parse_law_label(x) for x in costs.law]
    profiles = []
    for sc in scenes:
        t0 = time.perf_counter()
        profiles.append(profile_scene(sc, laws=laws, seed=args.seed, scale=args.scale, costs=costs))
        if not args.quiet:
            prof = profiles[-1]
            print(f"{sc.name}: {prof.summary['width']} x {prof.summary['height']} profiled in "
                  f"{time.perf_counter() - t0:.2f} s ({', '.join(f'{k} {v:.2f}' for k, v in prof.seconds.items())})")
    note = f" (scale {args.scale:g}, density x {args.scale ** 2:g} to keep n)" if args.scale != 1 else ""
    paths, tables = write_profiles(profiles, args.out, advice=advice_table(profiles, max_tv=args.max_tv),
                                   title_note=note)
    if not args.quiet:
        _print_table(tables["scene_table1"][["scene", "method", "mean_pixel", "mean_group", "worst_group",
                                             "simd_efficiency", "zk16_over_this_worst_group", "paper_ms"]], args.quiet)
        _print_table(tables["scene_advice"][["scene", "max_tv", "law", "cost_mean_group", "tv_worst"]], args.quiet)
        print(f"\nwrote {len(paths)} figures and {len(tables)} CSV tables in {args.out}")
    return 0


def _cmd_images(args) -> int:
    scenes = [load_scene(path) for path in args.scenes]  # all validated before any work
    params = {"scale": args.scale, "frames": args.frames, "pan_px": args.pan_px, "zoom": args.zoom,
              "density_factor": args.density_factor, "tau": args.tau, "timing_scale": args.timing_scale}
    if args.methods:
        params["methods"] = args.methods
        params["animation_methods"] = args.methods
    if args.method:
        bad = _check_method_shaders(args, scenes, params)
        if bad:
            return bad
    t0 = time.perf_counter()
    paths, tables = write_images(scenes, args.out, seed=args.seed, **params)
    if not args.quiet:
        _print_table(tables["scene_images_flicker"][["scene", "method", "std_ratio", "pop_rate", "change_rate",
                                                     "truth_change_rate", "mean_ratio"]], args.quiet)
        _print_table(tables["scene_images_timing"], args.quiet)
        print(f"\nwrote {', '.join(str(p) for p in paths)} and CSV tables in {args.out} "
              f"({time.perf_counter() - t0:.1f} s)")
    return 0


def _check_method_shaders(args, scenes, params) -> int:
    """``images --method FILE``: compiles each user method shader (a compile error is bad input, exit 2),
    adds it to the methods (beside the truth and the smooth image unless --methods names others) and
    checks that it returns finite values on the first frame of every scene (exit 1 otherwise)."""
    names = []
    for path in args.method:
        names.append(shader_method(path).name)
    base = args.methods or "truth,smooth"
    params["methods"] = params["animation_methods"] = ",".join(dict.fromkeys(base.split(",") + names))
    for sc in scenes:
        small = with_directional_light(sc.scaled(args.scale, keep_n=True))
        inp = frame_inputs(small)
        for name in names:
            vals = make_method(name, Material.of(small)).image(inp, seed=args.seed)[inp.hit]
            if not np.isfinite(vals).all():
                print(f"method {name}: non-finite values on {int((~np.isfinite(vals)).sum())} of {vals.size} "
                      f"hit pixel values of scene {sc.name} (frame 0)", file=sys.stderr)
                return 1
    return 0


def _cmd_advise(args) -> int:
    for flag, value in (("--max-tv", args.max_tv), ("--max-rel-error", args.max_rel_error)):
        if value is not None and not value >= 0:
            raise ValueError(f"{flag} = {value!r} is invalid; expected a number >= 0 (inf for no limit)")
    if args.max_tv is None and args.max_rel_error is None:
        raise ValueError("no budget given; expected --max-tv and/or --max-rel-error")
    scene = load_scene(args.scene)
    costs = _scene_costs(args.costs)
    laws = None if costs is None else [parse_law_label(x) for x in costs.law]
    prof = profile_scene(scene, laws=laws, seed=args.seed, scale=args.scale, costs=costs,
                         schemes=sorted({args.scheme, "zk16_aniso", "db23_tetrahedral"}))
    advice = advise(prof, max_tv=args.max_tv, max_rel_error=args.max_rel_error, coverage=args.coverage,
                    per_regime=args.per_regime, scheme=args.scheme)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "advice.json").write_text(json.dumps(advice.to_dict(), indent=2, default=float) + "\n")
        advice.candidates.to_csv(out / "advice_candidates.csv", index=False)
    if args.json:
        print(json.dumps(advice.to_dict(), indent=2, default=float))
        return 0
    if not args.quiet:
        print(advice)
        _print_table(advice.candidates, args.quiet)
        if advice.per_regime is not None:
            a = advice.per_regime.attrs
            print(f"\nper regime (n bands), combined cost {a['cost_mean_group']:.4g} per group "
                  f"(worst {a['cost_worst_group']:.4g}; divergent groups pay each law's worst lane):")
            _print_table(advice.per_regime, args.quiet)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glintlab",
        description="Exact laws, samplers and metrics for the counting laws of glint rendering. "
                    "Exit status: 0 success, 1 a check failed, 2 bad input.")
    parser.add_argument("--version", action="version", version=f"glintlab {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("laws", help="list the registered counting laws")
    p.set_defaults(func=_cmd_laws)

    def common(p, out_default=None, plugins=True, store=False, out_help=None):
        if store:
            p.add_argument("--store", help="resumable store (JSON lines): finished rows are kept across interruptions")
            p.add_argument("--scheduler", metavar="ADDRESS",
                           help="run on the Dask scheduler at ADDRESS (tcp://host:8786); same table as a local run")
            p.add_argument("--workers", type=int, metavar="K",
                           help="run on a Dask LocalCluster of K worker processes on this machine")
            p.add_argument("--timeout", type=float, default=10.0,
                           help="seconds to wait for the scheduler to answer (default: 10)")
        p.add_argument("--out", default=out_default,
                       help=f"output directory (default: {out_help or out_default})")
        p.add_argument("--quiet", action="store_true", help="no tables on stdout, no progress bar")
        if plugins:
            p.add_argument("--plugin", action="append", metavar="LIB.so",
                           help="load a C++ plugin's laws first (repeatable)")

    p = sub.add_parser("run", help="run one experiment (JSON) to CSV, JSON and plots",
                       description="Runs an experiment file (data/schema/experiment.schema.json), or re-runs a "
                                   "results.json exactly. Writes results.csv, results.json and one PNG per metric.")
    p.add_argument("experiment", help="experiment JSON, or a results.json written by an earlier run")
    common(p, None, store=True, out_help="out/experiments/EXPERIMENT, the file's stem")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("sweep", help="sweep laws over an (n, p) grid from flags",
                       description="An experiment given by flags. Axes: numbers, 'standard', 'logspace:LO:HI:COUNT' "
                                   "(exponents of 10) or 'linspace:LO:HI:COUNT'. Laws: NAME or NAME:KEY=VALUE,...")
    p.add_argument("--laws", nargs="+", required=True,
                   help="laws (e.g. gated head_cf gaussian:rounding=round, or a Python law "
                        "mine.py:count[:n_uniforms=2,binning=round])")
    p.add_argument("--n", nargs="+", help="values of n (default: standard)")
    p.add_argument("--p", nargs="+", help="values of p (default: standard)")
    p.add_argument("--metrics", nargs="+", default=["tv", "mean_rel_err", "var_rel_err"],
                   help="tv chi2_distance hellinger kl js w1 ks mean_rel_err var_rel_err chi2_pvalue")
    p.add_argument("--reference", help="reference law (default: binomial)")
    p.add_argument("--samples", type=_count_arg, help="draws per grid point (default: exact distributions)")
    p.add_argument("--seed", type=int, default=1, help="seed (default: 1)")
    p.add_argument("--name", default="sweep", help="experiment name (default: sweep)")
    common(p, None, store=True, out_help="out/sweeps/NAME, NAME from --name")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("check", help="check error bounds; exit 1 on any violation",
                       description="Evaluates each bound of BOUNDS.json (law, regime, metric, maximum or minimum), "
                                   "prints a table and exits 1 if any bound is violated.")
    p.add_argument("bounds", nargs="?", default=str(data_path("bounds", "default.json")),
                   help="bounds file (default: the package's data/bounds/default.json)")
    p.add_argument("--junit", metavar="FILE.xml", help="also write JUnit XML (one testcase per bound)")
    p.add_argument("--quiet", action="store_true", help="print only violations")
    p.add_argument("--plugin", action="append", metavar="LIB.so", help="load a C++ plugin's laws first")
    p.set_defaults(func=_cmd_check)

    p = sub.add_parser("bench", help="ns/sample and accuracy per law: table and Pareto plot",
                       description="Times every law (or --laws) against numpy's binomial and measures its error "
                                   "against the exact binomial over the standard grid, in one run.")
    p.add_argument("--laws", nargs="+", help="laws as in sweep, Python laws FILE.py:FUNCTION included (default: every built-in approximate law and the binomial)")
    p.add_argument("--samples", type=_count_arg, default=10**6, help="draws per timed call (default: 1e6)")
    p.add_argument("--repeats", type=int, default=2, help="timed calls per point, best kept (default: 2)")
    p.add_argument("--seed", type=int, default=1)
    common(p, "out/bench")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("extremes", help="the numerical-extremes suite (docs/math/extremes.md) for every law",
                       description="Evaluates every law in float32 and float64 at extreme n, p and uniforms: finite, "
                                   "in [0, n], mean error, pmf mass; invalid inputs must raise clear errors. Writes "
                                   "extremes.html with failures highlighted.")
    p.add_argument("--laws", nargs="+", help="laws as in sweep, Python laws FILE.py:FUNCTION included (default: every registered law and blend)")
    p.add_argument("--samples", type=_count_arg, default=4096, help="ordinary draws per point (default: 4096)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--strict", action="store_true", help="exit 1 if any check fails")
    common(p, "out/extremes")
    p.set_defaults(func=_cmd_extremes)

    p = sub.add_parser("shader", help="a shader's counting function run on Vulkan: verdict (exit 0/1/2) and report",
                       description="Compiles FILE (HLSL or GLSL defining float ENTRY(float n, float p, float4 u)) "
                                   "inside glintlab's compute kernel, runs it on a Vulkan device (lavapipe without a "
                                   "GPU) and measures it: chi-square and TV against the exact pmf of --against at "
                                   "DB23's Figure 9 points, a TV map over the standard grid, row-by-row agreement "
                                   "with --twin, the extremes suite, ns per evaluation. Exit 0: every check passes; "
                                   "1: one fails; 2: bad input (a compile error, an unknown law).")
    p.add_argument("file", nargs="?", help="the shader source file (.hlsl, .glsl, ...; always a path, never code)")
    p.add_argument("--emit", metavar="NAME", help="print the shipped shader NAME (or its law's name) in --lang (default hlsl) "
                   "as one self-contained file, includes inlined, and exit")
    p.add_argument("--entry", default="count", help="the counting function (default: count)")
    p.add_argument("--lang", choices=["hlsl", "glsl"], help="the language (default: from the extension)")
    p.add_argument("--uniforms", type=int, default=2, help="uniforms the function reads, 0 to 4 (default: 2)")
    p.add_argument("--against", default="binomial", help="the law the shader claims to approximate (default: binomial)")
    p.add_argument("--twin", help="a C++ law computing the same in float32, compared row by row")
    p.add_argument("-D", "--define", action="append", default=[], metavar="NAME=VALUE", help="a define (repeatable)")
    p.add_argument("-I", "--include", action="append", default=[], metavar="DIR", help="an include folder (repeatable)")
    p.add_argument("--device", default="auto", help="auto (default: a GPU if any, else lavapipe), gpu, cpu, an index or a name")
    p.add_argument("--bounds", metavar="B.json", help="also check these error bounds, the shader standing in for --against")
    p.add_argument("--samples", type=_count_arg, default=10**6, help="draws per Figure 9 point (default: 1e6)")
    p.add_argument("--grid-samples", type=_count_arg, default=4096, help="draws per standard-grid point (default: 4096)")
    p.add_argument("--grid-stride", type=_count_arg, default=2, help="every k-th n and p of the standard grid (default: 2)")
    p.add_argument("--rows", type=_count_arg, default=10**6, help="rows per point compared with --twin (default: 1e6)")
    p.add_argument("--speed-evaluations", type=_count_arg, default=10**6,
                   help="evaluations per timed call (default: 1e6)")
    p.add_argument("--timeout", type=float, default=60.0, help="seconds a kernel submission may run (default: 60)")
    p.add_argument("--seed", type=int, default=1)
    common(p, "out/shader")
    p.set_defaults(func=_cmd_shader)

    p = sub.add_parser("sampler", help="a direction sampler against its pdf: chi-square on adaptive bins (exit 0/1/2)",
                       description="Tests a registered sampler (gl.samplers(): beckmann, ggx, ggx_vndf, "
                                   "beckmann_vndf, vmf_mixture) or a sampler file against its pdf "
                                   "(docs/math/sampling.md). Exit 0 pass, 1 fail, 2 bad input. On failure the "
                                   "bins (NPZ, CSV) and a figure are written to --out.")
    p.add_argument("sampler", metavar="NAME_OR_FILE", help="a registered sampler name or a sampler file")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="a sampler parameter (repeatable): alpha=0.3, wo=0.6,0,0.8")
    p.add_argument("--samples", type=int, default=10**6, help="samples (default: 1e6)")
    p.add_argument("--seed", type=int, default=1, help="seed (default: 1)")
    p.add_argument("--bins", default="adaptive", help="'adaptive' (default) or a fixed grid N1xN2, e.g. 30x60")
    p.add_argument("--significance", type=float, default=1e-3,
                   help="fail below this p-value (the false-failure rate; default 1e-3)")
    p.add_argument("--write-always", action="store_true", help="write the bins and figure even on a pass")
    p.add_argument("--wrong", choices=WRONG_KINDS,
                   help="test a deliberately wrong variant of the sampler instead (it must fail: exit 1)")
    common(p, out_default="out/sampler", plugins=False)
    p.set_defaults(func=_cmd_sampler)

    p = sub.add_parser("aniso", help="anisotropic grid schemes against stratified facets in the ellipse",
                       description="DB23's trilinear and tetrahedral grids (area or log LOD weights, the shader's "
                                   "48-evaluation interpolation) and the ZK16 baseline against the exact ground "
                                   "truth over (n, r, phi, p): mean bias, variance ratio, TV, chi-square p; weight "
                                   "maps; a 1920 x 1080 image timed per scheme with its evaluation histogram.")
    p.add_argument("--full", action="store_true", help="the full grid (5 n, 14 r, 16 phi, p 0.1 and 0.5)")
    p.add_argument("--samples", type=_count_arg, help="draws per point (default: 10000, 40000 with --full)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--no-image", action="store_true", help="skip the image timing")
    common(p, "out/aniso", plugins=False)
    p.set_defaults(func=_cmd_aniso)

    p = sub.add_parser("profile", help="profile scenes: regime map, law errors, SIMD cost of grid schemes",
                       description="Per scene (data/schema/scene.schema.json): the (n, p, r) regime map, exact "
                                   "pixel-weighted law errors, evaluations and weight bias per grid scheme, a SIMD "
                                   "cost model (8 x 4 groups cost their worst pixel) and ZK16 / DB23 cost ratios. "
                                   "Writes CSV tables and PNG figures.")
    p.add_argument("scenes", nargs="+", metavar="SCENE.json", help="scene files (e.g. data/scenes/*.json)")
    p.add_argument("--scale", type=float, default=1.0,
                   help="resolution factor per side; the density follows so n per pixel is kept (default: 1)")
    p.add_argument("--max-tv", type=float, default=0.05, help="budget of the advisor table (default: 0.05)")
    p.add_argument("--costs", metavar="COSTS.csv",
                   help="law costs (law, ns_per_eval, ns_per_trial), e.g. a scene_cost_units.csv, instead of "
                        "measuring them: reproducible costs")
    p.add_argument("--seed", type=int, default=1)
    common(p, "out/scenes", plugins=False)
    p.set_defaults(func=_cmd_profile)

    p = sub.add_parser("images", help="glint images of scenes per method, their flicker, an animation",
                       description="Per scene (data/schema/scene.schema.json), under one directional light: the glint "
                                   "image (NDF term) of each image method along a camera path of sub-pixel pans and "
                                   "zoom steps, the flicker of each against the facet ground truth "
                                   "(docs/math/glint_images.md), a PNG panel, a flicker plot, a GIF of the first scene "
                                   "and seconds per image. Writes CSV tables and the figures.")
    p.add_argument("scenes", nargs="+", metavar="SCENE.json", help="scene files (e.g. data/scenes/*.json)")
    p.add_argument("--scale", type=float, default=0.2,
                   help="resolution factor per side; the density follows so n per pixel is kept (default: 0.2)")
    p.add_argument("--frames", type=int, default=8, help="frames of the camera path (default: 8)")
    p.add_argument("--pan-px", type=float, default=0.25, help="pan step in pixels (default: 0.25)")
    p.add_argument("--zoom", type=float, default=0.99, help="distance factor per zoom step (default: 0.99)")
    p.add_argument("--density-factor", type=float, default=0.0625,
                   help="facet density x this (default: 1/16, sparse glints; 1: the files' N)")
    p.add_argument("--tau", type=float, default=2.0, help="glint threshold in units of D(h) (default: 2)")
    p.add_argument("--methods", help="comma-separated image methods (default: all registered; must include truth)")
    p.add_argument("--method", action="append", metavar="FILE.hlsl",
                   help="your own method shader (float glint(GlintInput g), docs/guide/shaders.md), rendered "
                        "beside the truth and the smooth image; repeatable")
    p.add_argument("--timing-scale", type=float, default=1.0,
                   help="resolution factor of the timed image of the first scene (default: 1, 1920 x 1080)")
    p.add_argument("--seed", type=int, default=1)
    common(p, "out/images", plugins=False)
    p.set_defaults(func=_cmd_images)

    p = sub.add_parser("advise", help="the cheapest counting law meeting an error budget on a scene",
                       description="Profiles the scene and picks the law of least mean SIMD group cost whose "
                                   "per-pixel error meets the budget on --coverage of the pixels.")
    p.add_argument("scene", metavar="SCENE.json")
    p.add_argument("--max-tv", type=float, help="largest TV to the binomial per pixel")
    p.add_argument("--max-rel-error", type=float, help="largest relative intensity error |E[K]/(n p) - 1| per pixel")
    p.add_argument("--coverage", type=float, default=1.0, help="share of pixels that must meet it (default: 1)")
    p.add_argument("--per-regime", action="store_true", help="one law per n band, combined SIMD cost")
    p.add_argument("--scheme", default="db23_tetrahedral", help="grid scheme the cost is modelled on "
                                                                  "(default: db23_tetrahedral)")
    p.add_argument("--scale", type=float, default=1.0, help="resolution factor per side (default: 1)")
    p.add_argument("--costs", metavar="COSTS.csv", help="law costs instead of measuring them")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--json", action="store_true", help="print the recommendation as JSON")
    common(p, None, plugins=False, out_help="none: the advice is printed, no files are written")
    p.set_defaults(func=_cmd_advise)

    p = sub.add_parser("report", help="the main job: every figure family, as out/report/index.html",
                       description="Runs the sections of a report configuration (default: "
                                   "glintlab/data/report/default.json) and writes index.html, report.json, CSV tables "
                                   "and PNG figures. --only re-runs some sections and rebuilds the page from the "
                                   "section records already in --out. Exit 1 if a check fails (a sampler's "
                                   "chi-square p < 1e-4, a violated error bound), 2 on bad input.")
    p.add_argument("--out", default="out/report", help="output directory (default: out/report)")
    p.add_argument("--config", help="report configuration JSON (default: glintlab/data/report/default.json)")
    p.add_argument("--only", nargs="+", metavar="SECTION", help="run only these sections (see --list)")
    p.add_argument("--list", action="store_true", help="list the configured sections and exit")
    p.add_argument("--quick", action="store_true", help="the configuration's quick sizes (make run QUICK=1)")
    p.add_argument("--seed", type=int, help="seed of every section (default: the configuration's, 1)")
    p.add_argument("--quiet", action="store_true", help="no tables on stdout, no progress bar")
    p.set_defaults(func=_cmd_report)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on bad usage, 0 on --help
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        _default_outputs(args)
        _prepare_outputs(args)
        return args.func(args)
    except ValueError as exc:
        print(f"glintlab {args.command}: {exc}", file=sys.stderr)
        return 2
    # Bad input that is not a ValueError: a path that cannot be read or written, a request larger than
    # memory, a document nested too deeply, a law file that does not parse. Exit 2 ("bad input") with
    # one line, never 1 ("a check failed") and never a traceback.
    except (NotImplementedError, OSError, MemoryError, RecursionError, SyntaxError) as exc:
        print(f"glintlab {args.command}: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"glintlab {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
