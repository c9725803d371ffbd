"""``pipeline run WORKFLOW``: run every analysis and write output/<name>/."""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.commands import add_links_arg, add_workflow_args


def add_args(parser: argparse.ArgumentParser) -> None:
    add_workflow_args(parser)
    parser.add_argument("--out", type=Path, default=Path("output"),
                        help="results go to OUT/<name>/ (default: output)")
    add_links_arg(parser)
    parser.add_argument("--rebuild", action="store_true", help="ignore cached reduced links")
    parser.add_argument("--workers", type=int, default=0,
                        help="processes for analysis cases (default: one per core)")


def run(args: argparse.Namespace) -> int:
    import logging
    import os

    from pipeline.invariants.cache import default_links_dir
    from pipeline.workflow import run_workflow

    # stage timings are logged at INFO: show them, so long runs show where they are
    logging.getLogger("pipeline.core.progress").setLevel(logging.INFO)
    workers = args.workers if args.workers > 0 else (os.cpu_count() or 1)
    res = run_workflow(args.workflow, out_root=args.out, sets=args.sets, quick=args.quick,
                       rebuild=args.rebuild, workers=workers,
                       cache_dir=args.links if args.links is not None else default_links_dir())
    man = res.manifest
    print(f"{res.workflow.name}: {man['status']} in {man['timings_s']['total']:.1f} s "
          f"-> {res.out_dir}")
    for name, cases in man["analyses"].items():
        for c in cases:
            tag = f" [{c['case']}]" if c["case"] else ""
            verdict = c.get("verdict", "ok" if c["success"] else "partial")
            mark = {"ok": "ok", "partial": f"PARTIAL: {c['message']}"}.get(verdict, "SUSPECT")
            if c.get("expected", "ok") != "ok":
                mark += f" (expected {c['expected']})"
            print(f"  {c['type']:<12} {name}{tag}: {c['outputs']} outputs, {c['seconds']} s, "
                  f"{mark}")
            for w in c.get("warnings", []):
                print(f"      {w}")
    print(f"  files: {', '.join(man['files'])}")
    for note in man.get("skipped_outputs", []):
        print(f"  skipped: {note}")
    return 0 if man["status"] == "ok" else 1
