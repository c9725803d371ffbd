"""``pipeline render RUN_FOLDER``: draw a finished run's plots, renders and animations
again from its saved results, with other settings (``--set outputs....``), running no
analysis."""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.commands import add_links_arg


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", type=Path,
                        help="a run's folder (output/<name>), holding its manifest.json")
    parser.add_argument("--set", dest="sets", action="append", default=[],
                        metavar="outputs.PATH=VALUE",
                        help="draw otherwise, e.g. outputs.renders.still.scale=50 "
                             "(repeatable)")
    add_links_arg(parser)


def run(args: argparse.Namespace) -> int:
    from pipeline.workflow.rerender import render_run

    files = render_run(args.run, args.sets, args.links)
    print(f"{args.run}: drew {len(files)} files again ({', '.join(files)}) and its report")
    return 0
