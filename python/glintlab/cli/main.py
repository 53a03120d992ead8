"""The `glintlab` command line. Exit status: 0 success, 1 a check failed, 2 bad input.

Subcommands, one module each in :mod:`glintlab.cli` (``add_parser(subparsers)`` and ``run(args) -> int``;
shared options in :mod:`glintlab.cli.common`): laws, run (one experiment), sweep (an experiment from
flags), check (error bounds), bench (speed against accuracy), extremes (numerical extremes of every law),
shader (a shader's counting function run on Vulkan: verdict and report), cost (a shader compiled for AMD
GPUs without one: registers, occupancy, cycles), sampler (a direction sampler
against its pdf), aniso (anisotropic grids against the ground truth), profile and advise (scenes), images
(glint images of scenes and their flicker), report (the main job). This module assembles them and turns
exceptions into exit statuses.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .._core import __version__
from . import advise, aniso, bench, check, cost, extremes, images, laws, profile, report, run, sampler, shader, sweep

# The order of `glintlab --help`.
COMMANDS = (laws, run, sweep, check, bench, extremes, shader, sampler, cost, aniso, profile, images, advise, report)


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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glintlab",
        description="Exact laws, samplers and metrics for the counting laws of glint rendering. "
                    "Exit status: 0 success, 1 a check failed, 2 bad input.")
    parser.add_argument("--version", action="version", version=f"glintlab {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub)
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
        # The output folders that depend on other arguments (run: the file's stem; sweep: --name).
        if getattr(args, "default_outputs", None):
            args.default_outputs(args)
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
