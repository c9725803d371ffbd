"""Command-line interface: a thin layer over library calls.

Each subcommand lives in ``pipeline/commands/<name>.py`` and provides
``add_args(parser)`` and ``run(args) -> int``; it is registered in
:data:`COMMANDS`. This is the only module that configures logging, turns
:class:`~pipeline.core.errors.PipelineError` into a message and an exit code,
and exits.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from pipeline import __version__
from pipeline.core.errors import PipelineError

#: subcommand name -> (module under pipeline.commands, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {}


def register(name: str, module: str, help_text: str) -> None:
    """Register subcommand ``name`` implemented by ``pipeline.commands.<module>``."""
    COMMANDS[name] = (module, help_text)


register("reduce", "reduce", "mesh, assemble and reduce one link; print its summary")
register("validate", "validate", "check a workflow YAML (file:line errors) without running it")
register("run", "run", "run a workflow: analyses, plots, renders, exports into output/<name>/")
register("study", "study", "mode-truncation and design studies of a workflow on Dask")
register("cache", "cache", "list or clear the shared cache of reduced links")
register("report", "report", "make a finished run's HTML report again from its folder")
register("render", "render", "draw a finished run's pictures again from its saved results")
register("preview", "preview", "build a workflow's machine and picture it with its frames, "
                               "before any analysis")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pipeline", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"pipeline {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an error (default: one line)")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (module, help_text) in COMMANDS.items():
        mod = importlib.import_module(f"pipeline.commands.{module}")
        p = sub.add_parser(name, help=help_text, description=help_text)
        mod.add_args(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``pipeline`` console command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args._run(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # every failure, expected or not, ends as one line
        if args.debug:
            raise
        code, line = error_line(exc)
        print(f"error: {line}", file=sys.stderr)
        return code


def error_line(exc: BaseException) -> tuple[int, str]:
    """(exit code, one line) for a failure: 2 for bad input and the environment (files,
    disk, memory), 3 for an internal error (with the advice to rerun with --debug)."""
    if isinstance(exc, PipelineError):
        return 2, str(exc)
    if isinstance(exc, OSError):
        where = exc.filename or ""
        what = exc.strerror or str(exc)
        return 2, f"{where}: {what}" if where else what
    if isinstance(exc, MemoryError):
        return 2, ("out of memory: the model is too large for this machine (coarser meshes, "
                   "fewer modes or fewer outputs)")
    return 3, (f"internal error ({type(exc).__name__}: {exc}); please report it with the "
               "output of 'pipeline --debug ...'")
