"""Write a run's outputs into its (temporary) folder: CSV/NPZ exports, plots, renders,
animations and the ParaView series. Returns the relative file names for the manifest."""

from __future__ import annotations

import csv
import logging
import time
from pathlib import Path

import numpy as np

from pipeline.core.atomic import folder_bytes
from pipeline.core.errors import ConfigError
from pipeline.core.progress import stage
from pipeline.workflow.names import slug
from pipeline.workflow.series import series

logger = logging.getLogger(__name__)


def _stem(r) -> str:
    return r.name + (f"_{slug(r.case)}" if r.case else "")


def _analysis_spec(wf, name):
    return next((i, a) for i, a in enumerate(wf.spec.analyses) if a.name == name)


def export_csv(path: Path, r, mech, markers) -> None:
    """Main histories of one result: time, coordinates, marker positions, actuator forces,
    joint reactions, energies, element states (one row per output time; the store's
    series, :func:`pipeline.workflow.store.result_series`, under the CSV's column names)."""
    from pipeline.workflow.store import result_series

    cols = {"time_s": r.t}
    for stored, unit, _, values in result_series(r, mech, markers):
        column = _csv_column(stored, unit)
        if column is not None:
            cols[column] = values
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        for row in zip(*cols.values()):
            w.writerow([f"{float(x):.12g}" for x in row])


def _csv_column(series: str, unit: str) -> str | None:
    """The CSV column of a store series (None: not in the CSV: rates, accelerations, the
    closure residual, modes): coordinates by name, the unit after the others."""
    kind, _, rest = series.partition(":")
    if kind == "q":
        return rest
    if kind == "marker":
        target, axis = rest.rsplit(":", 1)
        return f"{target}.{axis}_{unit}"
    if kind == "reaction":
        joint, component = rest.rsplit(":", 1)
        return f"reaction:{joint}.{component}_{unit.replace(' ', '')}"
    if kind == "force":
        return series
    if kind == "energy":
        return f"{series}_J"
    if kind == "state":
        return f"{series}_{unit}"
    return None


def export_modes_csv(path: Path, r) -> None:
    f, z = r.extra["frequencies_hz"], r.extra["damping_ratios"]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["mode", "frequency_hz", "damping_ratio"])
        for i, (a, b) in enumerate(zip(f, z)):
            w.writerow([i + 1, f"{a:.10g}", f"{b:.6g}"])


def export_npz(path: Path, r) -> None:
    arrays = {"t": r.t, "q": r.q, "qd": r.qd, "qdd": r.qdd,
              "coordinates": np.array(r.coordinates), "success": np.array(r.success),
              "message": np.array(r.message), "verdict": np.array(r.verdict),
              "warnings": np.array(list(r.warnings), dtype=str)}
    for k, v in r.forces.items():
        arrays[f"force:{k}"] = np.asarray(v)
    for k, v in r.energies.items():
        arrays[f"energy:{k}"] = np.asarray(v)
    for k, (_, v) in r.states.items():
        arrays[f"state:{k}"] = np.asarray(v)
    for k, v in r.extra.items():
        a = np.asarray(v) if not isinstance(v, tuple) else None
        if a is not None and a.dtype != object:
            arrays[k] = a
        elif a is not None and a.dtype == object and a.ndim == 1:
            arrays[k] = a.astype(str)
    np.savez_compressed(path, **arrays)


def _markers_of(m, a):
    return [tuple(s.split(".", 1)) for s in a.markers]


def write_exports(folder: Path, wf, machines, results, skipped: list[str]) -> list[str]:
    files = []
    ex = wf.spec.outputs.exports
    for name, rs in results.items():
        _, a = _analysis_spec(wf, name)
        for r in rs:
            mech = machines[r.case].mechanism
            stem = _stem(r)
            if not r.has_data:
                skipped.append(f"exports: {_why(r)}")
                continue
            if ex.csv:
                if r.type == "linearised":
                    export_modes_csv(folder / f"{stem}_modes.csv", r)
                    files.append(f"{stem}_modes.csv")
                export_csv(folder / f"{stem}.csv", r, mech, _markers_of(machines[r.case], a))
                files.append(f"{stem}.csv")
            if ex.npz:
                export_npz(folder / f"{stem}.npz", r)
                files.append(f"{stem}.npz")
    return files


def _plot(folder: Path, wf, machines, results, idx: int, p, skipped) -> str | None:
    from pipeline.post.plots import Curve, Panel, plot_panels

    rs = results[p.analysis]
    if p.cases is not None:
        known = [r.case for r in rs]
        bad = [c for c in p.cases if c not in known]
        if bad:
            raise wf.error("outputs", "plots", idx, "cases",
                           msg=f"expected case labels among {known}, got {bad}")
        rs = [r for r in rs if r.case in p.cases]
    rs = _with_data(rs, f"plot {p.name!r}", skipped)
    if not rs:
        return None
    from pipeline.post.units import DisplayUnits, to_display

    units = DisplayUnits(**(p.units or wf.spec.outputs.units).model_dump())
    panels = []
    for s in p.series:
        curves, unit, label = [], "", s
        for r in rs:
            mech, parts = machines[r.case].mechanism, machines[r.case].parts
            try:
                y = series(r, mech, s, parts)
                x = series(r, mech, p.x, parts) if s != "frequency" else None
            except ConfigError as exc:
                raise wf.error("outputs", "plots", idx, msg=str(exc)) from None
            yv, unit = to_display(y.values, y.unit, units)
            if x is None:
                xv, xl = np.arange(1, y.values.size + 1), "mode number"
            else:
                xv, xunit = to_display(x.values, x.unit, units)
                xl = f"{x.label}, {xunit}"
            curves.append(Curve(r.case or y.label, xv, yv))
            label = y.label
        # a path (a length against a length): equal axes, or the shape is distorted
        equal = p.x.split(":")[0] in ("marker", "deflection") and \
            s.split(":")[0] in ("marker", "deflection")
        panels.append(Panel(label if len(p.series) > 1 else (p.title or label), xl,
                            p.ylabel or f"{label}, {unit}", curves, equal=equal))
    path = folder / f"{p.name}.png"
    plot_panels(path, panels, suptitle=p.title if len(panels) > 1 else None)
    return path.name


def machine_shapes(m, links=None) -> dict:
    """LinkShape per link of a machine (only ``links``, if given): meshes of reduced links,
    boxes/cylinders/sticks else."""
    from pipeline.post import shapes as sh
    from pipeline.post.primitives import box_surface, cylinder_surface

    mech = m.mechanism
    out = {}
    for name, entry in m.workflow.spec.links.items():
        if links is not None and name not in links:
            continue
        link = mech.links[mech.link_index(name)]
        if name in m.parts:
            out[name] = sh.shape_from_reduced(m.parts[name].reduced, list(m.parts[name].modes),
                                              link=name)
            continue
        shape = entry.shape
        if shape is None and entry.type == "ground":
            continue
        if shape is not None and shape.type == "box":
            out[name] = sh.shape_from_surface(name, *box_surface(shape.size, shape.center))
        elif shape is not None and shape.type == "cylinder":
            out[name] = sh.shape_from_surface(name, *cylinder_surface(shape.start, shape.end,
                                                                      shape.radius))
        else:
            out[name] = sh.stick_shape(link, getattr(shape, "radius", 0.02))
    return out


def _scale(spec_scale):
    return None if spec_scale == "auto" else float(spec_scale)


def _pick(rs, case, wf, *path):
    if case is None:
        return rs[0]
    for r in rs:
        if r.case == case:
            return r
    raise wf.error(*path, msg=f"expected a case among {[r.case for r in rs]}, got {case!r}")


def _auto_scale(mech, shapes, Q) -> float:
    """Magnification that makes the largest elastic displacement ~5 % of the machine size.
    ``mech``, ``shapes``: one machine's, or one per q (:func:`pipeline.post.scene.configurations`)."""
    from pipeline.post.scene import configurations, posed_points

    size, peak = 1e-9, 0.0
    for m, shapes_q, q in configurations(mech, shapes, Q):
        for shp in shapes_q.values():
            P, d = posed_points(m, shp, q, scale=1.0)
            size = max(size, float(np.ptp(P, axis=0).max()))
            peak = max(peak, float(np.max(d, initial=0.0)))
    if peak <= 0:
        return 1.0
    raw = 0.05 * size / peak
    return float(10 ** np.floor(np.log10(raw))) if raw > 1 else 1.0


def rigid_configuration(mech, q) -> np.ndarray:
    """q with every modal coordinate zeroed: the undeformed machine for comparison."""
    q = np.array(q, dtype=float)
    q[mech.modal_coordinates] = 0.0
    return q


def picture_style(wf, **kw):
    """Style of a workflow's pictures: the ground drawn against its gravity."""
    from pipeline.post.scene import Style

    g = np.asarray(wf.spec.gravity, dtype=float)
    up = tuple(-g / np.linalg.norm(g)) if np.linalg.norm(g) > 0 else None
    return Style(up=up, **kw)


def _render(folder, wf, machines, results, idx, rs_spec, skipped) -> str | None:
    from pipeline.post.scene import render_machine, render_positions

    rs = results[rs_spec.analysis]
    path = folder / f"{rs_spec.name}.png"
    style = picture_style(wf, color=rs_spec.color)
    if rs_spec.case is None and len(rs) > 1 and rs[0].type == "static":
        rs = _with_data(rs, f"render {rs_spec.name!r}", skipped)
        if not rs:
            return None
        # each case drawn with its own machine: cases may keep different modes
        mechs = [machines[r.case].mechanism for r in rs]
        shapes = [machine_shapes(machines[r.case], rs_spec.links) for r in rs]
        Q = [r.q[-1] for r in rs]
        scale = _scale(rs_spec.scale) or _auto_scale(mechs, shapes, Q)
        render_positions(path, mechs, shapes, Q, [r.case for r in rs], scale=scale,
                         camera=rs_spec.camera,
                         title=_with_scale(rs_spec.title, scale) or f"{wf.name}: {rs[0].name}",
                         ghost_q=[rigid_configuration(mm, q) for mm, q in zip(mechs, Q)],
                         style=style)
        return path.name
    r = _pick(rs, rs_spec.case, wf, "outputs", "renders", idx, "case")
    if not r.has_data:
        skipped.append(f"render {rs_spec.name!r}: {_why(r)}")
        return None
    m = machines[r.case]
    shapes = machine_shapes(m, rs_spec.links)
    if rs_spec.at:
        ks = [int(np.argmin(np.abs(r.t - t))) for t in rs_spec.at]
        slack = 1e-9 * max(abs(r.t[-1] - r.t[0]), 1.0)
        outside = [t for t in rs_spec.at if not r.t[0] - slack <= t <= r.t[-1] + slack]
        if outside:  # a --quick run, a run that stopped early, or a typo
            logger.warning("%s: render %r: at %s s is outside the outputs of %r (%.4g to "
                           "%.4g s); the nearest are drawn, labelled with their own times",
                           wf.name, rs_spec.name, outside, r.label, r.t[0], r.t[-1])
    else:
        ks = [len(r.t) - 1]
    Q = [r.q[k] for k in ks]
    scale = _scale(rs_spec.scale) or _auto_scale(m.mechanism, shapes, Q)
    title = _with_scale(rs_spec.title, scale) or f"{wf.name}: {r.label}"
    # the undeformed machine as a wireframe where deformation is the point (static results)
    ghosts = ([rigid_configuration(m.mechanism, q) for q in Q]
              if r.type in ("static", "linearised") else [None] * len(Q))
    if len(Q) == 1:
        when = "" if r.type in ("static", "linearised") else f", t = {r.t[ks[0]]:.3g} s"
        render_machine(path, m.mechanism, shapes, Q[0], scale=scale, camera=rs_spec.camera,
                       title=f"{title}{when}", ghost_q=ghosts[0], style=style)
    else:
        render_positions(path, m.mechanism, shapes, Q, [f"t = {r.t[k]:.3g} s" for k in ks],
                         scale=scale, camera=rs_spec.camera, title=title,
                         ghost_q=None if ghosts[0] is None else ghosts, style=style)
    return path.name


def _with_scale(title: str | None, scale: float) -> str | None:
    """A render's title with ``{scale}`` replaced by the magnification drawn (plain text
    replacement: the title is the user's, never a format string)."""
    return None if title is None else title.replace("{scale}", f"{scale:g}")


def _animate(folder, wf, machines, results, idx, an, skipped) -> str | None:
    from pipeline.post.scene import animate_machine

    r = _pick(results[an.analysis], an.case, wf, "outputs", "animations", idx, "case")
    if not r.has_data:
        skipped.append(f"animation {an.name!r}: {_why(r)}")
        return None
    m = machines[r.case]
    shapes = machine_shapes(m, an.links)
    scale = _scale(an.scale) or _auto_scale(m.mechanism, shapes, r.q[:: max(1, len(r.t) // 10)])
    path = folder / f"{an.name}.{an.format}"
    animate_machine(path, m.mechanism, shapes, r.t, r.q, scale=scale, fps=an.fps,
                    max_frames=an.max_frames, camera=an.camera,
                    style=picture_style(wf, line_px=4.0, color=an.color))
    return path.name


def _vtu(folder, machines, results, max_frames: int, budget_mb: float | None) -> list[str]:
    """One series per result with data. The run's size budget is shared out in order of
    length: what a short series (a static case: one frame) leaves goes to the longer ones."""
    from pipeline.post.vtk_series import write_peak_stress, write_vtk_series

    files = []
    todo = sorted((r for rs in results.values() for r in rs if len(r.t) >= 1),
                  key=lambda r: min(len(r.t), max_frames))
    left = None if budget_mb is None else budget_mb * 1e6
    for i, r in enumerate(todo):
        m = machines[r.case]
        sub = folder / "vtk" / _stem(r)
        share = None if left is None else left / (len(todo) - i)
        shapes = machine_shapes(m)
        pvd = write_vtk_series(sub, m.mechanism, shapes, r.t, r.q, name=_stem(r),
                               max_steps=max_frames, max_bytes=share)
        peak = write_peak_stress(sub / f"{_stem(r)}_peak_stress.vtu", m.mechanism, shapes,
                                 r.t, r.q)
        if peak is not None:
            files.append(str(peak.relative_to(folder)))
        if left is not None:
            left -= folder_bytes(sub)
        files.append(str(Path(pvd).relative_to(folder)))
    return files


def _convergence(folder, machines, results, c, skipped) -> list[str]:
    from pipeline.post.study_plot import plot_convergence
    from pipeline.workflow.study import convergence, write_convergence_csv

    missing = [r for r in results[c.analysis] if not r.has_data]
    if missing:
        skipped.append(f"convergence {c.name!r}: " + "; ".join(_why(r) for r in missing))
        return []
    short = [r for r in results[c.analysis] if not r.success]
    if short:
        skipped.append(f"convergence {c.name!r}: compared over the common times only: "
                       + "; ".join(f"{_what(r)} stopped at t = {r.t[-1]:.6g} s" for r in short))
    conv = convergence(results[c.analysis], machines, c.series, c.reference)
    write_convergence_csv(folder / f"{c.name}.csv", conv)
    plot_convergence(folder / f"{c.name}.png", conv.labels, conv.relative,
                     reference=conv.reference, title=c.title)
    return [f"{c.name}.csv", f"{c.name}.png"]


def write_outputs(folder: Path, wf, machines, results, timings: dict,
                  skipped: list[str] | None = None) -> list[str]:
    """All requested outputs of a run into ``folder``; returns their relative names. An
    output whose analysis (or case) has no results is skipped with a note in ``skipped``;
    the others are written."""
    skipped = [] if skipped is None else skipped
    # a run that stopped early draws what its histories allow; an output they cannot give
    # is skipped and listed (a complete run's failure is a bug and is raised)
    partial = any(not r.success for rs in results.values() for r in rs)

    def each(what: str, name: str, draw) -> list:
        try:
            out = draw()
        except Exception as exc:  # any drawing failure, but only of a partial run's outputs
            if not partial or isinstance(exc, MemoryError):
                raise
            skipped.append(f"{what} {name!r}: not drawn from the partial histories "
                           f"({type(exc).__name__}: {exc})")
            return []
        return out if isinstance(out, list) else [out]

    files = []
    t0 = time.perf_counter()
    with stage(f"{wf.name}: exports"):
        files += each("exports", "all", lambda: write_exports(folder, wf, machines, results,
                                                                skipped))
    timings["exports"] = time.perf_counter() - t0
    outs = wf.spec.outputs
    t0 = time.perf_counter()
    with stage(f"{wf.name}: plots"):
        for i, p in enumerate(outs.plots):
            files += each("plot", p.name, lambda i=i, p=p: _plot(folder, wf, machines, results,
                                                                  i, p, skipped))
    timings["plots"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    with stage(f"{wf.name}: renders"):
        for i, r in enumerate(outs.renders):
            files += each("render", r.name, lambda i=i, r=r: _render(
                folder, wf, machines, results, i, r, skipped))
        for i, an in enumerate(outs.animations):
            files += each("animation", an.name, lambda i=i, an=an: _animate(
                folder, wf, machines, results, i, an, skipped))
    timings["renders"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    for c in outs.convergence:
        files += each("convergence", c.name, lambda c=c: _convergence(folder, machines, results,
                                                                       c, skipped))
    timings["studies"] = time.perf_counter() - t0
    if outs.exports.vtu:
        t0 = time.perf_counter()
        with stage(f"{wf.name}: ParaView series"):
            files += each("ParaView series", "vtu", lambda: _vtu(
                folder, machines, results, outs.exports.vtu_frames, outs.exports.vtu_mb))
        timings["vtu"] = time.perf_counter() - t0
    for note in skipped:
        logger.warning("%s: %s", wf.name, note)
    return [f for f in files if f is not None]


def _with_data(rs: list, output: str, skipped: list[str]) -> list:
    """The results of ``rs`` that hold data; a note in ``skipped`` for each left out."""
    skipped += [f"{output}: left out: {_why(r)}" for r in rs if not r.has_data]
    return [r for r in rs if r.has_data]


def _what(r) -> str:
    return f"analysis {r.name!r}" + (f" case {r.case!r}" if r.case else "")


def _why(r) -> str:
    return f"no results in {_what(r)} ({r.message})"
