"""``pipeline reduce LINK_SPEC``: build (or reuse) a reduced link and print its summary."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from pipeline.invariants.participation import DIRECTIONS


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", type=Path, help="link spec YAML (see meshes/*.yaml)")
    parser.add_argument("--links", "--out", dest="links", type=Path, default=None,
                        help="the reduced-link cache (default: $FLEXMECH_LINKS, else "
                             "output/links), shared with run, validate --build and study")
    parser.add_argument("--rebuild", action="store_true", help="ignore a cached artifact")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--render", action="store_true",
                        help="also render the first mode shapes beside the artifact "
                             "(<name>_modes.png)")
    parser.add_argument("--hdf5", type=Path, metavar="FILE",
                        help="also write the reduced link to FILE in the open HDF5 format "
                             "of docs/hdf5_format.md, for other tools")
    parser.add_argument("--mesh", type=Path, metavar="FILE",
                        help="also write the link's FE mesh to FILE (.inp, .bdf, .msh, .vtu) in "
                             "its geometry frame, m, for another FE tool")
    parser.add_argument("--convergence", action="store_true",
                        help="also reduce the link on a mesh twice as coarse and print each "
                             "frequency's estimated discretisation error")


def run(args: argparse.Namespace) -> int:
    from pipeline.core.errors import MeshError, ModalError, PipelineError
    from pipeline.invariants.adequacy import coverage_report
    from pipeline.invariants.cache import default_links_dir
    from pipeline.workflow.link_build import reduce_cached
    from pipeline.workflow.link_spec import load_link_spec_lines, locate

    args.links = args.links if args.links is not None else default_links_dir()
    spec, lines = load_link_spec_lines(args.spec)
    if args.convergence and spec.geometry.type == "mesh":
        from pipeline.core.errors import ConfigError

        raise ConfigError(f"{args.spec}: --convergence: link {spec.name!r} comes from the mesh "
                          f"file {spec.geometry.path}, which this tool does not coarsen: "
                          "compare its frequencies with a coarser mesh from the FE tool")
    try:
        link, status, artifact = reduce_cached(spec, args.spec.parent, args.links, args.rebuild,
                                               args.spec)
    except PipelineError as exc:  # name the spec's file, line and field
        default = ("geometry",) if isinstance(exc, MeshError) else \
            ("modes",) if isinstance(exc, ModalError) else ()
        raise type(exc)(locate(str(exc), spec, args.spec, lines, default)) from None
    summary = {**link.summary(), "artifact": str(artifact),
               "cache": status, "mesh_quality": dict(link.meta.get("mesh", {})),
               "effective_mass_fraction": _effective_masses(link),
               "static_coverage": coverage_report(link)}
    if args.convergence:
        summary["frequency_convergence"] = _convergence(spec, args, link)
    if args.hdf5 is not None:
        from pipeline.invariants.hdf5 import write_hdf5

        summary["hdf5"] = str(write_hdf5(link, args.hdf5))
    if args.mesh is not None:
        from pipeline.invariants.mesh_export import write_link_mesh

        summary["mesh_file"] = str(write_link_mesh(link, args.mesh))
    if args.render:
        from pipeline.post.render import render_modes

        summary["render"] = str(render_modes(link, artifact.parent / f"{link.name}_modes.png"))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        _print_table(summary)
    return 0


def _print_table(s: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    con = Console()
    t = Table(title=f"reduced link '{s['name']}' ({s['kind']}, cache {s['cache']})")
    t.add_column("quantity")
    t.add_column("value")
    t.add_row("nodes / DOF", f"{s['nodes']} / {s['dof']}")
    t.add_row("mass", f"{s['mass_kg']:.6g} kg")
    t.add_row("centre of mass (body frame)", _vec(s["center_of_mass_m"]) + " m")
    t.add_row("inertia about CoM", "\n".join(_vec(r) for r in s["inertia_kgm2"]) + " kg m^2")
    t.add_row("frequencies", ", ".join(f"{f:.4g}" for f in s["frequencies_hz"]) + " Hz")
    t.add_row("frames", ", ".join(s["frames"]))
    if s.get("reference_conditions"):
        t.add_row("modes relative to", s["reference_conditions"])
    gs = s.get("geometric_stiffening")
    t.add_row("geometric stiffening", f"{gs['inertia_cases']} inertia cases; forces at "
              f"{', '.join(gs['frame_forces'])}" if gs else "off")
    for k, v in s["mesh_quality"].items():
        t.add_row(f"CAD check: {k}", f"{v:.3g}")
    for k, v in s["stage_seconds"].items():
        t.add_row(f"time: {k}", f"{v:.3f} s")
    if s.get("factorisation"):
        t.add_row("factorisation of the clamped stiffness", s["factorisation"])
    if s.get("peak_memory_mib") is not None:
        t.add_row("peak memory of the process", f"{s['peak_memory_mib'] / 1024:.2f} GiB")
    t.add_row("artifact", s["artifact"])
    if "hdf5" in s:
        t.add_row("HDF5 export", s["hdf5"])
    if "mesh_file" in s:
        t.add_row("FE mesh", s["mesh_file"])
    if "render" in s:
        t.add_row("mode shapes", s["render"])
    con.print(t)
    for frame, rows in s["effective_mass_fraction"].items():
        e = Table(title=f"effective mass at interface '{frame}', % of the link's mass (t) "
                        "and inertia about the interface (r)")
        for col in ("mode", "Hz", *DIRECTIONS):
            e.add_column(col, justify="right")
        for k, (f, row) in enumerate(zip(s["frequencies_hz"], rows, strict=True)):
            e.add_row(str(k), f"{f:.4g}", *(_pct(x) for x in row))
        e.add_row("sum", "", *(_pct(x) for x in np.sum(rows, axis=0)), style="bold")
        con.print(e)
    _print_coverage(con, s["static_coverage"])
    if "frequency_convergence" in s:
        _print_convergence(con, s["frequency_convergence"])


def _convergence(spec, args, link) -> dict:
    """The link reduced again with its mesh size doubled (in the link cache too), and each
    frequency's estimated discretisation error."""
    from pipeline.invariants.adequacy import frequency_convergence, mesh_warnings
    from pipeline.workflow.link_build import reduce_cached

    g = spec.geometry
    key = "geometry.mesh_size" if g.type == "solid" else "geometry.element_size"
    size = g.mesh_size if g.type == "solid" else g.element_size
    field = key.split(".")[1]
    coarse_spec = spec.model_copy(update={"geometry": g.model_copy(update={field: 2 * size})})
    coarse, _, _ = reduce_cached(coarse_spec, args.spec.parent, args.links, args.rebuild,
                                 args.spec)
    rate = 2 if g.type == "solid" and g.order == 1 else 4
    rows = frequency_convergence(link.frequencies_hz, coarse.frequencies_hz, rate)
    return {"coarse_size_m": 2 * size, "rate": rate, "rows": rows,
            "warnings": mesh_warnings(link.name, rows, key)}


def _print_convergence(con, conv: dict) -> None:
    from rich.table import Table

    c = Table(title=f"frequency convergence: the same modes on a mesh twice as coarse "
                    f"({conv['coarse_size_m']:.4g} m); error estimated as the change / "
                    f"(2^{conv['rate']} - 1)")
    for col in ("mode", "Hz", "coarse Hz", "change %", "est. error %"):
        c.add_column(col, justify="right")
    for r in conv["rows"]:
        c.add_row(str(r["mode"]), f"{r['hz']:.6g}", f"{r['coarse_hz']:.6g}",
                  f"{100 * r['change']:+.3g}", f"{100 * r['error']:+.2g}")
    con.print(c)
    for w in conv["warnings"]:
        con.print(f"[yellow]warning:[/yellow] {w}")


def _print_coverage(con, report: dict) -> None:
    """The static compliance the modes carry at each frame, and a line per shortfall."""
    from rich.table import Table

    if not report["rows"]:
        return
    c = Table(title="static compliance the modes carry at each frame, % of the full FE "
                    "model's (the link held at its reference only; the machine's own "
                    "supports are checked when a workflow builds it)")
    for col in ("frame", "direction", "share"):
        c.add_column(col, justify="right")
    for r in report["rows"]:
        c.add_row(r["frame"], r["direction"], f"{100 * r['share']:.1f}",
                  style=None if r["relevant"] else "dim")  # dim: too stiff to matter
    con.print(c)
    for w in report["warnings"]:
        con.print(f"[yellow]warning:[/yellow] {w}")


def _effective_masses(link) -> dict[str, list[list[float]]]:
    """Per interface, each mode's effective-mass fraction in its six rigid directions."""
    from pipeline.invariants.participation import effective_mass_fractions

    return {f.name: effective_mass_fractions(link, f.name).round(6).tolist()
            for f in link.frames if f.kind == "interface"}


def _pct(x: float) -> str:
    return f"{100 * x:.1f}" if x >= 5e-4 else "."


def _vec(v) -> str:
    return "[" + ", ".join(f"{x: .5g}" for x in np.asarray(v)) + "]"
