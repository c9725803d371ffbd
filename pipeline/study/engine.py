"""Running a study's cases on ``dask.distributed`` and writing its table.

* The reduced links are built once, in this process, into the content-addressed link
  cache; they reach the workers through Dask with the workflow's files
  (:mod:`pipeline.study.bundle`: sent once per worker), so workers need no shared disk and
  a case never reduces a link another built.
* Each case is a task (:func:`run_case`, a plain function of plain values): it loads the
  base workflow with the case's overrides, runs the analyses and returns its status, the
  compared series and the derived outputs. A worker that dies costs only the case it held
  (distributed retries it elsewhere, or it comes back "lost" with the reason).
* A truncation case also records the world positions of every flexible link's frames and
  the machine's lowest frequencies (:func:`world_evidence`): evidence in the machine's
  terms, not only in a link's own axes.
* Results are kept per case (``cases/<hash>.npz``) and in one table (``cases.parquet`` and
  ``cases.csv``: one row per case, parameters, outputs, status, seconds); a case whose
  input hash is already in the table with a result is not run again, so a study resumes.
* Progress: a live table of the cases under the running stage on a terminal, a log line
  per finished case otherwise.
"""

from __future__ import annotations

import json
import logging
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.core.atomic import atomic_open, atomic_path, save_npz_atomic
from pipeline.core.cases import WORKER_TIMEOUT, CaseLost, Task, run_cases
from pipeline.core.errors import ConfigError, PipelineError
from pipeline.core.progress import stage
from pipeline.invariants.cache import default_links_dir
from pipeline.study.bundle import BundlePlugin
from pipeline.study.cases import Case, study_cases
from pipeline.study.spec import load_study, mode_text

logger = logging.getLogger(__name__)

#: rows with these statuses are results; the others (error, lost) are run again
KEPT = ("ok", "suspect", "partial")


@dataclass(frozen=True)
class StudyResult:
    """What a study wrote: folder, the table rows (list of dicts), the mode
    recommendation per link (or {}), and how many cases ran now."""

    folder: Path
    rows: list[dict]
    recommendation: dict
    ran: int


def run_case(base: str, quick: bool, overrides: dict, label: str, analyses, cache_dir: str,
             series_names: list, outputs: list, world: dict | None = None) -> dict:
    """One case (runs on a worker): status, message, seconds, the compared series
    ({"analysis:series": (t, values)}) and the derived outputs ({name: value}).

    ``world`` ({link: [frame, ...]}, a truncation study's links) adds the world-frame
    evidence: each frame's ground position and elastic displacement over every analysis
    ("analysis:world|link.frame", "analysis:elastic|link.frame", (T, 3) m) and the machine's
    lowest frequencies at static equilibrium at t = 0 ("frequencies", Hz; absent where the
    machine has no equilibrium to linearise about).
    """
    from pipeline.workflow import build_machine, load_workflow
    from pipeline.workflow.analyses import run_analysis
    from pipeline.workflow.series import marker_positions, series

    t0 = time.perf_counter()
    try:
        wf = load_workflow(base, quick=quick)
        wf = wf.for_case(overrides, label) if overrides else wf
        m = build_machine(wf, cache_dir)
        names = analyses or [a.name for a in wf.spec.analyses]
        results = {n: run_analysis(m, n) for n in names}
        out_series = {}
        for n, r in results.items():
            for s in series_names:
                out_series[f"{n}:{s}"] = (np.asarray(r.t), series(r, m.mechanism, s,
                                                                 m.parts).values)
        for n, r in results.items():
            q = np.asarray(r.q)
            for link, frames in (world or {}).items():
                for f in frames:
                    out_series[f"{n}:world|{link}.{f}"] = (
                        np.asarray(r.t), marker_positions(m.mechanism, q, link, f))
                    out_series[f"{n}:elastic|{link}.{f}"] = (
                        np.asarray(r.t), marker_positions(m.mechanism, q, link, f, True))
        if world:
            f_hz = start_frequencies(m)
            if f_hz.size:
                out_series["frequencies"] = (np.arange(f_hz.size, dtype=float), f_hz)
        derived = {}
        for o in outputs:
            r = results[o["analysis"] or names[0]]
            v = series(r, m.mechanism, o["series"], m.parts).values
            derived[o["name"]] = _reduce(v, o["reduce"])
        worst = [r.verdict for r in results.values()]
        status = "partial" if "partial" in worst else "suspect" if "suspect" in worst else "ok"
        message = "; ".join(f"{n}: {'; '.join((r.message, *r.warnings))}"
                            for n, r in results.items() if r.verdict != "ok")
    except PipelineError as exc:
        return {"status": "error", "message": str(exc), "seconds": time.perf_counter() - t0,
                "series": {}, "outputs": {}}
    return {"status": status, "message": message, "seconds": time.perf_counter() - t0,
            "series": out_series, "outputs": derived}


def run_bundled_case(key: str, workflow: str, quick: bool, overrides: dict, label: str,
                     analyses, series_names: list, outputs: list,
                     world: dict | None = None) -> dict:
    """:func:`run_case` from the study's files as the worker unpacked them
    (:class:`~pipeline.study.bundle.BundlePlugin`; ``key`` the bundle's, ``workflow`` the
    base workflow's path in it)."""
    from pipeline.study.bundle import bundle_folder

    root = bundle_folder(key)
    if not (root / ".complete").is_file():
        return {"status": "error", "message": "the study's files were not unpacked on this "
                "worker (see its log)", "seconds": 0.0, "series": {}, "outputs": {}}
    return run_case(str(root / workflow), quick, overrides, label, analyses,
                    str(root / "links"), series_names, outputs, world)


#: how many of the machine's lowest frequencies a truncation study compares
FREQUENCIES = 3


def start_frequencies(m) -> np.ndarray:
    """The machine's lowest :data:`FREQUENCIES` natural frequencies (Hz) about its static
    equilibrium at t = 0 (drivers held), or none where that equilibrium or its
    linearisation cannot be had (a machine without one: it says nothing then)."""
    from pipeline.dynamics.linearize import vibration_modes
    from pipeline.dynamics.statics import static_equilibrium

    try:
        st = static_equilibrium(m.system, m.q0, t=0.0)
        if not st.success:
            return np.zeros(0)
        f = vibration_modes(m.system, st.q, t=0.0).frequencies_hz
    except (PipelineError, np.linalg.LinAlgError, ValueError):
        return np.zeros(0)
    f = f[np.isfinite(f) & (f > 0)]
    return np.sort(f)[:FREQUENCIES]


def _reduce(v: np.ndarray, how: str) -> float:
    v = np.asarray(v, dtype=float)
    if v.size == 0:
        return float("nan")
    return float({"max": np.max, "min": np.min, "peak": lambda x: np.max(np.abs(x)),
                  "final": lambda x: x[-1], "rms": lambda x: np.sqrt(np.mean(x ** 2)),
                  "mean": np.mean}[how](v))


def run_study(study: str | Path, *, out_root: str | Path = "output", workers: int = 2,
              scheduler: str | None = None, cache_dir: str | Path | None = None,
              worker_timeout: float = WORKER_TIMEOUT) -> StudyResult:
    """Run the cases of ``study`` that the table does not hold yet; write the table, the
    recommendation and the manifest into ``out_root/<study name>/``.

    Parameters
    ----------
    workers : processes of the local cluster (ignored with ``scheduler``).
    scheduler : address of an existing Dask scheduler (``tcp://host:8786``).
    cache_dir : reduced-link cache of this process (default: the shared one,
        :func:`pipeline.invariants.cache.default_links_dir`); the
        workers get the links they need through Dask and need no shared filesystem.
    worker_timeout : seconds the study waits while the cluster has no worker at all
        before the cases left are ``lost`` (an external cluster whose workers died).

    Raises
    ------
    ConfigError
        Bad study or base workflow (named by file and line); distributed not installed.
    """
    from pipeline.workflow.names import check_folder_owner, check_run_folder, run_name
    from pipeline.workflow.run import output_lock

    spec, base = load_study(study)
    out_root = Path(out_root)
    name = run_name(spec.name, Path(study), f"{study}: name")
    folder = out_root / name
    cache = Path(cache_dir) if cache_dir is not None else default_links_dir()
    check_run_folder(folder, cache)
    with output_lock(out_root, name):  # the lock a run of that name takes too
        check_folder_owner(folder, "study", f"{study}: name")
        return _study_locked(study, spec, base, folder, cache, workers, scheduler,
                             worker_timeout)


def _study_locked(study, spec, base, folder, cache, workers, scheduler,
                  worker_timeout) -> StudyResult:
    from pipeline.workflow import build_machine, load_workflow

    wf = load_workflow(base, quick=spec.quick)
    if spec.set:
        wf = _with_set(wf, spec.set, study)
    _check_names(spec, wf, study)
    flexible = [n for n, e in wf.spec.links.items() if e.type == "flexible"]
    cases = study_cases(spec, base, flexible, _inputs(wf))
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cases").mkdir(exist_ok=True)
    old = {r["input_hash"]: r for r in _read_rows(folder) if r.get("status") in KEPT}
    todo = [c for c in cases if c.input_hash not in old or not _case_intact(folder, c)]
    with stage(f"study {spec.name}: links"):
        machine = build_machine(wf, cache)  # reductions shared by content hash with every case
        machines = [machine]
        for c in todo:
            if any(".spec" in k for k in c.overrides):
                machines.append(build_machine(wf.for_case(c.overrides, c.label), cache))
        _check_mode_counts(spec, wf, machine, todo, study)
    world = world_frames(machine, spec, flexible)
    done = dict(old)

    def finished(c: Case, row: dict) -> None:
        # the table after every case: a kill loses at most the cases then running
        done[c.input_hash] = row
        _write_table(folder, [done[k.input_hash] for k in cases if k.input_hash in done])

    if todo:
        from pipeline.study.bundle import study_bundle

        bundle = study_bundle(wf, _inputs(wf) + _geometry_files(wf),
                              _artifact_folders(machines, cache), cache)
        _run(spec, bundle, todo, workers, scheduler, folder, world, finished, worker_timeout)
    rows = [done.get(c.input_hash) for c in cases]
    recommendation = recommend(spec, cases, folder) if spec.truncation else {}
    _write_table(folder, rows)
    _write_manifest(folder, spec, base, cases, rows, recommendation)
    with stage(f"study {spec.name}: plots"):
        _plots(folder, spec, cases, rows, recommendation)
    return StudyResult(folder, rows, recommendation, len(todo))


def _plots(folder, spec, cases, rows, recommendation) -> None:
    """Convergence chart per truncated link; each output against each numeric parameter
    of the design cases."""
    try:
        from pipeline.post.study_plot import plot_convergence, plot_outputs
    except ImportError:  # pragma: no cover - matplotlib comes with the render extra
        logger.warning("study %s: no plots (matplotlib is not installed)", spec.name)
        return
    for link, rec in recommendation.items():
        ev = rec["evidence"]
        if not ev:
            continue
        counts = list(ev)  # the study's order, leanest first
        names = sorted({k for e in ev.values() for k in e})
        plot_convergence(folder / f"truncation_{link}.png", [mode_text(k) for k in counts],
                         {n: [ev[k].get(n, np.nan) for k in counts] for n in names},
                         reference=mode_text(rec["reference"]),
                         title=f"{link}: difference from {mode_text(rec['reference'])} "
                               f"(recommended {mode_text(rec['recommended'])}, tolerance "
                               f"{100 * rec['tolerance']:g} %)")
    design = [r for c, r in zip(cases, rows, strict=True) if c.kind == "design"]
    params = sorted({k[4:] for c in cases if c.kind == "design" for k in
                     (f"set:{p}" for p in c.overrides)})
    for o in spec.outputs:
        for p in params:
            plot_outputs(folder / f"{o.name}_vs_{p.replace('.', '_')}.png", design, o.name, p)


def _geometry_files(wf) -> list[Path]:
    """The geometry files (STEP, .geo) the base workflow's link specs read."""
    from pipeline.workflow.build import _link_spec, is_reduced_file
    from pipeline.workflow.link_build import link_request

    files = []
    for name, entry in wf.spec.links.items():
        spec = getattr(entry, "spec", None)
        if spec is not None and not is_reduced_file(spec):  # a reduced file: an input
            spec, base_dir = _link_spec(wf, name, entry)
            files += link_request(spec, base_dir)[1]
    return files


def _artifact_folders(machines, cache: Path) -> list[str]:
    """The folders of the link cache holding the reduced links of ``machines``."""
    from pipeline.invariants.cache import artifact_folder

    out = set()
    for m in machines:
        for part in m.parts.values():
            folder = artifact_folder(part.reduced.name, part.reduced.meta.get("input_hash", ""))
            if (Path(cache) / folder).is_dir():
                out.add(folder)
    return sorted(out)


def _inputs(wf) -> list[Path]:
    """Files the base workflow reads besides itself: link specs and driver tables."""
    files = []
    for entry in wf.spec.links.values():
        spec = getattr(entry, "spec", None)
        if isinstance(spec, str):
            files.append((wf.base_dir / spec).resolve())
    for d in getattr(wf.spec, "drivers", {}).values():
        f = d.get("file") if isinstance(d, dict) else None
        if f:
            files.append((wf.base_dir / f).resolve())
    return [f for f in files if f.is_file()]


def _check_names(spec, wf, study) -> None:
    names = [a.name for a in wf.spec.analyses]
    for a in spec.analyses or []:
        if a not in names:
            raise ConfigError(f"{study}: analyses: {a!r} is not an analysis of "
                              f"{wf.path.name} ({names})")
    flexible = [n for n, e in wf.spec.links.items() if e.type == "flexible"]
    if spec.truncation is not None:
        for link in spec.truncation.links or []:
            if link not in flexible:
                raise ConfigError(f"{study}: truncation.links: {link!r} is not a flexible "
                                  f"link of {wf.path.name} ({flexible})")


def world_frames(machine, spec, flexible) -> dict[str, list[str]]:
    """{link: its frames} of every flexible link (its stored and workflow frames but the
    body frame) when the study truncates modes: whose world positions the cases record."""
    if spec.truncation is None:
        return {}
    mech = machine.mechanism
    return {link: [f.name for f in mech.links[mech.link_index(link)].frames
                   if f.name != "body"] for link in flexible}


def _with_set(wf, overrides: dict, study) -> Any:
    """The base workflow with the study's ``set:``; an override it refuses is named at its
    own line of the study file (not the base workflow's)."""
    from pipeline.workflow.yaml_io import load_yaml

    try:
        return wf.for_case(overrides, "study set")
    except ConfigError:
        lines = load_yaml(study)[1]
        for key, value in overrides.items():
            try:
                wf.for_case({key: value}, "study set")
            except ConfigError as exc:
                # the base workflow's first line of it, without its file:line: path
                detail = str(exc).splitlines()[0].split(": case 'study set': ", 1)[-1]
                detail = re.sub(r"^.*?:\d+: [\w.\[\]-]+: ", "", detail)
                raise ConfigError(f"{study}:{lines.get(('set', key), lines.get(('set',), 1))}"
                                  f": set.{key}: {detail}") from None
        raise


def _check_mode_counts(spec, wf, machine, cases, study) -> None:
    """Every truncation case's kept modes exist in its link's reduction, before any worker
    starts: a count the spec does not compute is one line here, not a column of failed
    cases after the cluster came up."""
    from pipeline.workflow.build import kept_modes
    from pipeline.workflow.yaml_io import load_yaml

    for c in cases:
        if c.kind != "truncation" or c.link not in machine.parts:
            continue
        try:
            entry = wf.for_case(c.overrides, c.label).spec.links[c.link]
            kept_modes(machine.parts[c.link].reduced, entry.modes,
                       getattr(entry, "plane", None))
        except ConfigError as exc:
            lines = load_yaml(study)[1]
            line = lines.get(("truncation", "modes", c.order), lines.get(("truncation",), 1))
            raise ConfigError(f"{study}:{line}: truncation.modes.{c.order}: case "
                              f"{c.label!r}: {exc}; nothing was run") from None


def _case_file(folder: Path, c: Case) -> Path:
    return folder / "cases" / f"{c.input_hash[:16]}.npz"


def _run(spec, bundle, todo, workers, scheduler, folder, world, finished,
         worker_timeout: float = WORKER_TIMEOUT) -> None:
    """Run ``todo`` with the one case runner (:func:`pipeline.core.cases.run_cases`) from
    ``bundle`` (the study's files, sent once to each worker); each finished case's row
    goes to ``finished(case, row)`` as it arrives (its series saved first). A case whose
    workers died, or that the cluster had no worker left to run, is ``lost`` with the
    reason."""
    t = spec.truncation
    names = list(t.series) if t is not None else []
    outs = [o.model_dump() for o in spec.outputs]
    tasks = [Task(c.label, run_bundled_case,
                  (bundle.key, bundle.workflow, spec.quick, {**spec.set, **c.overrides},
                   c.label, spec.analyses, names, outs,
                   world if c.kind == "truncation" else None), f"case-{c.input_hash[:16]}")
             for c in todo]

    def record(k: int, res, error) -> tuple[str, float]:
        if error is not None:
            res = _lost(str(error) if isinstance(error, CaseLost)
                        else f"{type(error).__name__}: {error}")
        c = todo[k]
        if res["status"] in KEPT:
            _save_case(folder, c, res)
        finished(c, _row(c, res))
        return res["status"], res["seconds"]

    logger.info("study %s: sending its files and reduced links (%.1f MB) to the workers",
                spec.name, bundle.size / 1e6)
    run_cases(tasks, title=f"study {spec.name}", record=record, workers=workers,
              scheduler=scheduler, plugin=BundlePlugin(bundle), worker_timeout=worker_timeout)


def _lost(why: str) -> dict:
    return {"status": "lost", "message": why, "seconds": float("nan"), "series": {},
            "outputs": {}}


def _row(c: Case, res: dict) -> dict:
    row = {"case": c.label, "kind": c.kind, "link": c.link, "modes": c.modes,
           "input_hash": c.input_hash, "status": res["status"], "message": res["message"],
           "seconds": float(res["seconds"])}
    row.update({f"set:{k}": json.dumps(v) for k, v in c.overrides.items()})
    row.update({f"out:{k}": v for k, v in res["outputs"].items()})
    return row


def _save_case(folder: Path, c: Case, res: dict) -> None:
    arrays = {}
    for k, (t, v) in res["series"].items():
        arrays[f"t|{k}"] = np.asarray(t)
        arrays[f"v|{k}"] = np.asarray(v)
    save_npz_atomic(_case_file(folder, c), **arrays)


def case_series(folder: Path, c: Case) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{"analysis:series": (t, values)} saved for case ``c``."""
    with np.load(_case_file(folder, c), allow_pickle=False) as data:
        keys = sorted({k.split("|", 1)[1] for k in data.files})
        return {k: (data[f"t|{k}"], data[f"v|{k}"]) for k in keys}


def recommend(spec, cases: list[Case], folder: Path) -> dict[str, dict]:
    """Per link: the leanest kept-mode entry (in the study's order) whose every compared
    series and world figure (:func:`world_evidence`) stays within the tolerance (relative
    RMS difference over the common times) of the richest (the last), and the evidence:
    {"recommended": label, "reference": label, "tolerance": tol, "evidence": {label:
    {series: relative}}}; without the richest case's results, "recommended" is None and
    "why" says so."""
    t = spec.truncation
    out: dict[str, dict] = {}
    by_link: dict[str, list[Case]] = {}
    for c in cases:
        if c.kind == "truncation":
            by_link.setdefault(c.link, []).append(c)
    for link, cs in by_link.items():
        ok = sorted((c for c in cs if _case_file(folder, c).is_file()), key=lambda c: c.order)
        richest = max(cs, key=lambda c: c.order)
        if not ok or ok[-1] is not richest:  # no reference: a leaner case is no stand-in
            out[link] = {"recommended": None, "reference": richest.modes,
                         "tolerance": t.tolerance, "evidence": {},
                         "why": f"the reference case ({richest.modes}) did not finish"}
            continue
        ref = ok[-1]
        ref_series = case_series(folder, ref)
        evidence: dict[str, dict[str, float]] = {}
        for c in ok:
            s = case_series(folder, c)
            evidence[c.modes] = {k: _relative(s[k][1], v) for k, (_, v) in ref_series.items()
                                 if k in s and not _is_world(k)}
            evidence[c.modes].update(world_evidence(s, ref_series))
        good = [c.modes for c in ok[:-1] if evidence[c.modes] and
                max(evidence[c.modes].values()) <= t.tolerance]
        out[link] = {"recommended": good[0] if good else ref.modes, "reference": ref.modes,
                     "tolerance": t.tolerance, "evidence": evidence}
    return out


def _is_world(key: str) -> bool:
    return key == "frequencies" or "world|" in key or "elastic|" in key


def world_evidence(s: dict, ref: dict) -> dict[str, float]:
    """The world-frame part of a truncation case's evidence against the reference's: per
    analysis, the largest RMS distance over time between a flexible link's frame in the
    case and in the reference (ground positions), relative to the largest RMS elastic
    displacement of any such frame in the reference -- how far the machine's shape moves
    against how far it deforms, seen where the machine puts it (a boom too stiff at its lug
    turns less about its foot: its own-axes deflection can agree while its tip does not);
    and the largest relative difference of the machine's lowest frequencies."""
    def rms(P):
        return float(np.sqrt(np.mean(np.sum(np.asarray(P) ** 2, axis=1)))) if len(P) else 0.0

    out = {}
    for n in sorted({k.split(":", 1)[0] for k in ref if ":world|" in k}):
        keys = [k for k in ref if k.startswith(f"{n}:world|") and k in s]
        if not keys:
            continue
        scale = max(rms(ref[k.replace("world|", "elastic|")][1]) for k in keys)
        diff = 0.0
        for k in keys:
            T = min(len(s[k][1]), len(ref[k][1]))
            diff = max(diff, rms(np.asarray(s[k][1])[:T] - np.asarray(ref[k][1])[:T]))
        out[f"{n}: flexible links in the world"] = (diff / scale if scale > 0 else
                                                    (0.0 if diff == 0 else float("inf")))
    if "frequencies" in ref and "frequencies" in s:
        f, fr = np.asarray(s["frequencies"][1]), np.asarray(ref["frequencies"][1])
        k = min(f.size, fr.size)
        if k:
            out[f"lowest {k} machine frequencies"] = float(np.max(np.abs(f[:k] - fr[:k])
                                                                  / fr[:k]))
    return out


def _relative(y: np.ndarray, ref: np.ndarray) -> float:
    k = min(len(y), len(ref))
    if k == 0:
        return float("inf")
    scale = float(np.sqrt(np.mean(ref[:k] ** 2)))
    d = float(np.sqrt(np.mean((y[:k] - ref[:k]) ** 2)))
    return d / scale if scale > 0 else (0.0 if d == 0 else float("inf"))


def _set_aside(path: Path, why: str) -> None:
    """Move a damaged study file out of the way (kept for inspection), with one line."""
    aside = path.with_name(f"{path.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}")
    path.replace(aside)
    logger.warning("study: %s is damaged (%s); moved to %s, its cases run again", path, why,
                   aside.name)


def _read_rows(folder: Path) -> list[dict]:
    """The table's rows; a table that cannot be read, or whose rows lack ``input_hash`` or
    ``status``, is set aside (its cases run again) rather than stop the study."""
    path = folder / "cases.parquet"
    if not path.is_file():
        return []
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        rows = pq.read_table(path).to_pylist()
        bad = next((r for r in rows if not (isinstance(r.get("input_hash"), str)
                                             and isinstance(r.get("status"), str))), None)
        if bad is not None:
            raise ValueError("a row without input_hash and status")
    except (pa.ArrowException, OSError, ValueError) as exc:
        _set_aside(path, f"{type(exc).__name__}: {exc}")
        return []
    return rows


def _case_intact(folder: Path, c: Case) -> bool:
    """Whether case ``c``'s saved series are there and readable; a damaged file (a
    truncated write from another tool, a full disk) is set aside and the case runs again."""
    path = _case_file(folder, c)
    if not path.is_file():
        return False
    import zipfile

    try:
        with np.load(path, allow_pickle=False) as data:
            for k in data.files:
                data[k]
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        _set_aside(path, f"{type(exc).__name__}: {exc}")
        return False
    return True


def _write_table(folder: Path, rows: list[dict]) -> None:
    import csv

    import pyarrow as pa
    import pyarrow.parquet as pq

    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    full = [{k: r.get(k) for k in keys} for r in rows]
    with atomic_path(folder / "cases.parquet") as tmp:
        pq.write_table(pa.Table.from_pylist(full), tmp)
    with atomic_open(folder / "cases.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(full)


def _write_manifest(folder, spec, base, cases, rows, recommendation) -> None:
    from pipeline.workflow.link_build import versions

    def plain(x: Any):
        if isinstance(x, dict):
            return {str(k): plain(v) for k, v in x.items()}
        if isinstance(x, float) and not np.isfinite(x):
            return None
        return x

    from pipeline.core.hashing import content_hash

    manifest = {"study": spec.model_dump(mode="json"), "workflow": str(base),
                "workflow_hash": content_hash({}, (Path(base),)), "versions": versions(),
                "cases": [{"case": c.label, "overrides": c.overrides,
                           "input_hash": c.input_hash, "status": r["status"]}
                          for c, r in zip(cases, rows, strict=True)],
                "recommendation": plain(recommendation)}
    with atomic_open(folder / "study.json", "w") as fh:
        json.dump(manifest, fh, indent=2, default=str)
