"""``pipeline validate WORKFLOW``: check a workflow without running it."""

from __future__ import annotations

import argparse

from pipeline.commands import add_links_arg, add_workflow_args


def add_args(parser: argparse.ArgumentParser) -> None:
    add_workflow_args(parser)
    parser.add_argument("--build", action="store_true",
                        help="also build the machine (reduces links; checks every name)")
    add_links_arg(parser)


def run(args: argparse.Namespace) -> int:
    from pipeline.workflow import build_machine, load_workflow

    wf = load_workflow(args.workflow, args.sets, args.quick)
    spec = wf.spec
    print(f"{args.workflow}: valid workflow '{wf.name}': {len(spec.links)} links, "
          f"{len(spec.joints)} joints, {len(spec.forces)} force elements, "
          f"{len(spec.analyses)} analyses ({', '.join(a.name for a in spec.analyses)})")
    if args.build:
        import time

        from pipeline.invariants.cache import default_links_dir
        from pipeline.workflow.run import build_cases, check_outputs

        links = args.links if args.links is not None else default_links_dir()
        tic = time.perf_counter()
        m = build_machine(wf, links)
        check_outputs(wf, m)
        build_cases(wf, m, links)
        print(f"built in {time.perf_counter() - tic:.1f} s: {m.mechanism.n} coordinates "
              f"({', '.join(m.mechanism.coordinates)})")
        for line in machine_report(m):
            print(f"  {line}")
    return 0


def machine_report(m) -> list[str]:
    """Mobility, coordinates and initial energy of a built machine, one fact per line."""
    import numpy as np

    from pipeline.dynamics import energies
    from pipeline.kinematics import closure, dof_report

    mech, system = m.mechanism, m.system
    rep = dof_report(mech, m.q0, list(system.drivers))
    n_modal = len(mech.modal_coordinates)
    lines = [f"DOF {rep.dof} = {rep.n_coordinates} coordinates - {rep.rank} independent "
             f"closure constraints ({n_modal} modal, {len(system.drivers)} driven, "
             f"{len(rep.free)} free joint coordinates"
             + (f", {len(rep.passive)} passive)" if rep.passive else ")"),
             f"independent coordinates: {list(rep.prescribed) + list(rep.free)}",
             f"dependent coordinates: {list(rep.dependent)}"]
    if rep.redundant:
        lines.append(f"redundant constraints ({len(rep.redundant)}; kept by the DAE "
                     f"formulation, their reactions minimum-norm): {list(rep.redundant)}")
    for p in rep.passive:
        lines.append(f"passive motion: link '{p.link}' spins about its own axis")
    tree = closure(mech, m.q0, m.qd0).tree
    e = energies(system, tree, m.q0, m.qd0)
    lines.append("initial energy: " + ", ".join(f"{k} {v:.6g} J" for k, v in e.items())
                 + f" (max |q'| {float(np.abs(m.qd0).max(initial=0.0)):.4g})")
    from pipeline.kinematics.joints import gimbal_locks

    return (lines + [f"model warning: {w}" for w in m.model_warnings]
            + [f"singular start: {w}" for w in gimbal_locks(mech, m.q0)])
