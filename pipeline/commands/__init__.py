"""CLI subcommands: each module has ``add_args(parser)`` and ``run(args) -> int``; the
arguments several share are added here, once."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_links_arg(parser: argparse.ArgumentParser) -> None:
    """``--links DIR``: the shared cache of reduced links."""
    parser.add_argument("--links", type=Path, default=None,
                        help="the reduced-link cache shared by reduce, validate --build, "
                             "preview, run, render and study (default: $FLEXMECH_LINKS, "
                             "else output/links)")


def add_workflow_args(parser: argparse.ArgumentParser) -> None:
    """``WORKFLOW``, ``--set PATH=VALUE`` and ``--quick``: a workflow as a run reads it."""
    parser.add_argument("workflow", type=Path, help="workflow YAML (see workflows/)")
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="PATH=VALUE",
                        help="override a value, e.g. analyses.swing.t_end=0.5 (repeatable)")
    parser.add_argument("--quick", action="store_true",
                        help="coarse meshes and short runs (the file's quick: overrides)")
