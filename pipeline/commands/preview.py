"""``pipeline preview WORKFLOW``: the machine as built, before any analysis runs: its
mobility and coordinates printed, and a picture of it at its initial configuration with
every frame drawn (joint frames, interfaces, markers; a joint's axis is its frames' z)."""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.commands import add_links_arg, add_workflow_args


def add_args(parser: argparse.ArgumentParser) -> None:
    add_workflow_args(parser)
    parser.add_argument("--out", type=Path, default=None,
                        help="the picture (default: output/previews/<name>.png)")
    parser.add_argument("--camera", default="iso",
                        help="a camera as the workflow's renders take (default iso)")
    add_links_arg(parser)


def run(args: argparse.Namespace) -> int:
    from pipeline.commands.validate import machine_report
    from pipeline.invariants.cache import default_links_dir
    from pipeline.post.scene import render_machine
    from pipeline.post.views import check_camera
    from pipeline.workflow import build_machine, load_workflow
    from pipeline.workflow.outputs import machine_shapes, picture_style
    from pipeline.workflow.run import check_outputs

    check_camera(args.camera)
    wf = load_workflow(args.workflow, args.sets, args.quick)
    links = args.links if args.links is not None else default_links_dir()
    m = build_machine(wf, links)
    check_outputs(wf, m)
    print(f"{args.workflow}: '{wf.name}' as built: {m.mechanism.n} coordinates")
    for line in machine_report(m):
        print(f"  {line}")
    path = args.out if args.out is not None else Path("output") / "previews" / f"{wf.name}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    render_machine(path, m.mechanism, machine_shapes(m), m.q0, camera=args.camera,
                   title=f"{wf.name}: initial configuration (preview; frames x red, y green, "
                         f"z blue)", style=picture_style(wf, frames=True))
    print(f"picture: {path}")
    return 0
