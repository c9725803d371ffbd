"""``pipeline report RUN_FOLDER``: make a finished run's HTML report again from what it
wrote (its manifest, plots, animations and tables), without running anything."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", type=Path,
                        help="a run's folder (output/<name>), holding its manifest.json")


def run(args: argparse.Namespace) -> int:
    from pipeline.core.errors import ConfigError
    from pipeline.post.report import write_report

    try:
        path = write_report(args.run)
    except FileNotFoundError as exc:
        raise ConfigError(str(exc)) from None
    print(f"{path} ({path.stat().st_size / 1e6:.1f} MB): open it in a browser")
    return 0
