"""``pipeline validate WORKFLOW``: check a workflow without running it."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("workflow", type=Path, help="workflow YAML (see workflows/)")
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="PATH=VALUE",
                        help="override a value, e.g. analyses.swing.t_end=0.5 (repeatable)")
    parser.add_argument("--quick", action="store_true", help="apply the file's quick: overrides")
    parser.add_argument("--build", action="store_true",
                        help="also build the machine (reduces links; checks every name)")


def run(args: argparse.Namespace) -> int:
    from pipeline.workflow import build_machine, load_workflow

    wf = load_workflow(args.workflow, args.sets, args.quick)
    spec = wf.spec
    print(f"{args.workflow}: valid workflow '{wf.name}': {len(spec.links)} links, "
          f"{len(spec.joints)} joints, {len(spec.forces)} force elements, "
          f"{len(spec.analyses)} analyses ({', '.join(a.name for a in spec.analyses)})")
    if args.build:
        from pipeline.workflow.run import check_outputs

        m = build_machine(wf)
        check_outputs(wf, m)
        print(f"built: {m.mechanism.n} coordinates ({', '.join(m.mechanism.coordinates)})")
    return 0
