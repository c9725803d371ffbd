"""``run_workflow``: load -> build (per case) -> analyses -> outputs, atomically in
``output/<name>/`` with a ``manifest.json`` (input hash, versions, timings, status).

Results are written into a hidden sibling folder and swapped in at the end, so a
run that raises leaves the previous results untouched and nothing half-written.
An analysis that fails numerically (integration stopped, no equilibrium) is
not an exception: its partial history is written and marked ``partial`` in the
manifest.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.core.atomic import folder_lock, replace_dir
from pipeline.core.cases import CaseLost, Task, run_cases
from pipeline.core.errors import ConfigError, PipelineError
from pipeline.core.progress import stage
from pipeline.invariants.cache import default_links_dir
from pipeline.post.report import REPORT, write_report
from pipeline.workflow.analyses import AnalysisResult, run_analysis
from pipeline.workflow.build import Machine, build_machine
from pipeline.workflow.history import history_slot, prune_history
from pipeline.workflow.link_build import versions
from pipeline.workflow.load import Workflow, load_workflow
from pipeline.workflow.names import check_folder_owner, check_run_folder
from pipeline.workflow.series import check_series, coordinate_unit
from pipeline.workflow.store import STORE, run_rows, write_store

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced.

    Attributes
    ----------
    workflow : the loaded Workflow.  out_dir : output/<name>.
    machine : the base Machine (no case overrides).
    machines : case label -> Machine built for that case ("" is the base).
    results : analysis name -> [AnalysisResult per case] (one entry without cases).
    manifest : the manifest.json content.
    """

    workflow: Workflow
    out_dir: Path
    machine: Machine
    machines: dict = field(default_factory=dict)
    results: dict = field(default_factory=dict)
    manifest: dict = field(default_factory=dict)

    def result(self, analysis: str, case: str | None = None) -> AnalysisResult:
        """The result of ``analysis`` (its case ``case``; default the first)."""
        rs = self.results[analysis]
        if case is None:
            return rs[0]
        for r in rs:
            if r.case == case:
                return r
        raise KeyError(f"analysis {analysis!r} has no case {case!r}; cases: "
                       f"{[r.case for r in rs]}")


def _case_machine(wf: Workflow, base: Machine, cache: dict, case, cache_dir, rebuild) -> Machine:
    if case is None:
        return base
    key = json.dumps(case.set, sort_keys=True, default=str)
    if key not in cache:
        cache[key] = build_machine(wf.for_case(case.set, case.label), cache_dir, rebuild)
    m = cache[key]
    if m.workflow.case != case.label:  # same overrides, other label
        m = Machine(wf.for_case(case.set, case.label), m.system, m.q0, m.qd0, m.parts)
    return m


def build_cases(wf: Workflow, base: Machine, cache_dir, rebuild: bool = False,
                cache: dict | None = None) -> dict[str, Machine]:
    """The machine of every analysis case (label -> Machine; "" the base), built before
    any analysis runs so that a bad case override is found first, in one line naming the
    file, the case and the YAML path."""
    cache = {} if cache is None else cache
    machines = {"": base}
    for a in wf.spec.analyses:
        for case in a.cases:
            machines[case.label] = _case_machine(wf, base, cache, case, cache_dir, rebuild)
    return machines


def check_outputs(wf: Workflow, m: Machine) -> None:
    """Markers of the analyses and series of the plots and studies must exist in the built
    machine (and suit their analysis type): checked before any analysis runs."""
    mech = m.mechanism
    stateful = [f.name for f, _ in m.system.state_slices]
    for i, a in enumerate(wf.spec.analyses):
        if stateful and a.type not in ("kinematic", "linearised") and not (
                a.type == "dynamic" and a.method == "generalized_alpha") and not (
                a.type == "static" and a.trapped):
            what = a.type if a.type != "dynamic" else f"dynamic, method {a.method}"
            raise wf.error("analyses", i, "type", msg=(
                f"force element(s) {stateful} have states of their own (hydraulic "
                f"pressures) that only a dynamic analysis by method generalized_alpha "
                f"integrates, a linearised one holds at their start values, or a static "
                f"one with trapped: true traps behind closed valves; this one is {what}"))
        for k, marker in enumerate(a.markers):
            link, _, frame = marker.partition(".")
            frames = [f.name for f in mech.links[mech.link_index(link)].frames] \
                if link in mech.link_names else None
            if frames is None or frame not in frames:
                known = sorted(mech.link_names) if frames is None else sorted(frames)
                raise wf.error("analyses", i, "markers", k,
                               msg=f"expected link.frame, got {marker!r} (known "
                                   f"{'links' if frames is None else 'frames of ' + link}: "
                                   f"{known})")
    types = {a.name: a.type for a in wf.spec.analyses}
    for i, p in enumerate(wf.spec.outputs.plots):
        for s in ([p.x] if p.x != "time" else []) + list(p.series):
            try:
                check_series(s, m.mechanism, types[p.analysis], m.parts,
                             m.system.state_names)
            except ConfigError as exc:
                raise wf.error("outputs", "plots", i, msg=str(exc)) from None
    for i, c in enumerate(wf.spec.outputs.convergence):
        a = wf.spec.analysis(c.analysis)
        labels = [x.label for x in a.cases]
        if len(labels) < 2:
            raise wf.error("outputs", "convergence", i, "analysis",
                           msg=f"analysis {a.name!r} needs at least two cases to compare")
        if c.reference is not None and c.reference not in labels:
            raise wf.error("outputs", "convergence", i, "reference",
                           msg=f"expected one of the cases {labels}, got {c.reference!r}")
        for s in c.series:
            try:
                check_series(s, m.mechanism, a.type, m.parts, m.system.state_names)
            except ConfigError as exc:
                raise wf.error("outputs", "convergence", i, msg=str(exc)) from None


def _case_result(wf: Workflow, case_set, label, analysis: str, cache_dir, rebuild):
    """One (analysis, case) in a worker process: build the case's machine and run."""
    case_wf = wf.for_case(case_set, label) if label else wf
    return run_analysis(build_machine(case_wf, cache_dir, rebuild), analysis)


def _run_parallel(wf, base, tasks, cache, machines, cache_dir, rebuild, workers, timings):
    """Analysis cases on a local cluster of ``workers`` processes (the one case runner,
    :func:`pipeline.core.cases.run_cases`); machines for the outputs are rebuilt here
    from the cached reductions (a System holds mapping proxies, which do not pickle)."""
    t0 = time.perf_counter()
    done = collect_cases(wf, base, tasks, cache_dir, rebuild, min(workers, len(tasks)))
    timings["analyses (parallel)"] = time.perf_counter() - t0
    results = {}
    for (a, case), r in zip(tasks, done):
        m = _case_machine(wf, base, cache, case, cache_dir, rebuild)
        machines[m.workflow.case] = m
        results.setdefault(a.name, []).append(r)
    return results


def collect_cases(wf, base, tasks, cache_dir, rebuild, workers: int = 2
                  ) -> list[AnalysisResult]:
    """Run every (analysis, case) of ``tasks`` with the one case runner and gather the
    results in order. Each case's result is kept as it arrives: a case whose worker died
    (killed, out of memory) and could not be run again comes back failed, naming the
    cause, and costs only itself. An error raised by a case (bad input) is raised here,
    as it was raised in the worker.

    Progress: a live table of the cases (queued, running, ok / partial / failed, seconds)
    under the running stage on a terminal; a log line per finished case otherwise."""
    run = uuid.uuid4().hex[:12]  # keys unique on a shared scheduler: no result reused
    jobs = [Task(f"{a.name}" + (f" / {case.label}" if case else ""), _case_result,
                 (wf, case.set if case else {}, case.label if case else "", a.name,
                  cache_dir, rebuild), f"{wf.name}-{k}-{run}")
            for k, (a, case) in enumerate(tasks)]
    done: list = [None] * len(tasks)
    t_sub = time.perf_counter()

    def record(k: int, value, error) -> tuple[str, float]:
        a, case = tasks[k]
        done[k] = case_outcome(wf, base, a, case.label if case else "", value, error)
        if error is not None:
            return "lost", time.perf_counter() - t_sub
        return value.verdict, value.timings.get("total", time.perf_counter() - t_sub)

    run_cases(jobs, title=wf.name, record=record, workers=workers)
    return done


def case_outcome(wf: Workflow, base: Machine, a, label: str, value, error):
    """The result of case ``label`` of analysis spec ``a`` from what its worker returned
    (``value``) or raised (``error``): a case lost to the cluster (its workers died,
    or none was left to run it: :class:`~pipeline.core.cases.CaseLost`) is a failed,
    empty result naming the cause (logged as a warning); the case's own error (bad input)
    is raised here as it was raised there."""
    if error is None:
        return value
    if not isinstance(error, CaseLost):
        raise error
    why = str(error)
    logger.warning("%s: analysis %r%s: %s", wf.name, a.name,
                   f" case {label!r}" if label else "", why)
    return lost_case(base, a, label, why)


def lost_case(base: Machine, a, label: str, why: str) -> AnalysisResult:
    """A failed, empty result of analysis spec ``a`` (case ``label``) saying ``why``."""
    n = base.mechanism.n
    empty = np.empty((0, n))
    return AnalysisResult(name=a.name, type=a.type, case=label, success=False, message=why,
                          coordinates=tuple(base.mechanism.coordinates), t=np.empty(0),
                          q=empty, qd=empty, qdd=empty)


def _remove_stale(out_root: Path, name: str) -> None:
    """Temporaries of earlier runs of this workflow that were killed (the caller holds the
    workflow's lock, so no live run owns one)."""
    for pattern in (f".{name}.partial-*", f".{name}.old-*"):
        for p in out_root.glob(pattern):
            logger.info("removing %s, left by an interrupted run", p)
            shutil.rmtree(p, ignore_errors=True)


@contextlib.contextmanager
def output_lock(out_root: Path, name: str):
    """The lock on ``out_root/name`` that every run and study of that name takes: a second
    one is refused at once (ConfigError), not queued."""
    with contextlib.ExitStack() as stack:
        try:  # only the acquisition: a BlockingIOError inside the run is the run's own
            stack.enter_context(folder_lock(out_root, name))
        except BlockingIOError:
            raise ConfigError(f"{out_root / name}: another run or study named {name!r} is "
                              "writing it; wait for it to finish") from None
        yield


def run_workflow(workflow: str | Path | Workflow, *, out_root: str | Path = "output",
                 sets=(), quick: bool = False, cache_dir: str | Path | None = None,
                 rebuild: bool = False, outputs: bool = True, workers: int = 1) -> RunResult:
    """Run every analysis of a workflow and write its outputs.

    Parameters
    ----------
    workflow : YAML path or a loaded Workflow (then ``sets``/``quick`` are ignored).
    out_root : results go to ``out_root/<name>/``.
    sets : ``"path=value"`` overrides.  quick : apply the file's ``quick:`` overrides.
    cache_dir : reduced-link cache (default: the shared one,
        :func:`pipeline.invariants.cache.default_links_dir`).
    rebuild : ignore cached reduced links.
    outputs : write plots, renders and exports (False: results only, for tests).
    workers : processes for the analysis cases (1 runs them in this process).

    Raises
    ------
    ConfigError
        Bad workflow (file:line: path: what was expected); nothing is written then.
    """
    wf = workflow if isinstance(workflow, Workflow) else load_workflow(workflow, sets, quick)
    out_root = Path(out_root)
    cache_dir = Path(cache_dir) if cache_dir is not None else default_links_dir()
    final = out_root / wf.name
    check_run_folder(final, cache_dir)
    tmp = out_root / f".{wf.name}.partial-{os.getpid()}"
    timings: dict[str, float] = {}
    t_start = time.perf_counter()
    with output_lock(out_root, wf.name):
        check_folder_owner(final, "run", f"{wf.path}: name")
        _remove_stale(out_root, wf.name)
        return _run_locked(wf, cache_dir, final, tmp, rebuild, outputs, workers, timings,
                           t_start)


def _run_locked(wf, cache_dir, final, tmp, rebuild, outputs, workers, timings,
                t_start) -> RunResult:
    """The run proper, under the workflow's lock: into ``tmp``, then swapped in."""
    from pipeline.workflow.outputs import write_outputs

    try:
        tmp.mkdir(parents=True)
        t0 = time.perf_counter()
        with stage(f"{wf.name}: build machine"):
            base = build_machine(wf, cache_dir, rebuild)
        timings["build"] = time.perf_counter() - t0
        check_outputs(wf, base)
        cache: dict = {}
        build_cases(wf, base, cache_dir, rebuild, cache)
        mobility = _mobility(wf, base)
        for w in base.model_warnings:
            logger.warning("%s: %s", wf.name, w)
        for w in base.model_notes:
            logger.info("%s: %s", wf.name, w)
        machines = {"": base}
        tasks = [(a, case) for a in wf.spec.analyses for case in (a.cases or [None])]
        if workers > 1 and len(tasks) > 1:
            results = _run_parallel(wf, base, tasks, cache, machines, cache_dir, rebuild,
                                    workers, timings)
        else:
            results = {}
            for a, case in tasks:
                t0 = time.perf_counter()
                label = f" [{case.label}]" if case else ""
                with stage(f"{wf.name}: {a.type} analysis '{a.name}'{label}"):
                    m = _case_machine(wf, base, cache, case, cache_dir, rebuild)
                    machines[m.workflow.case] = m
                    results.setdefault(a.name, []).append(run_analysis(m, a.name))
                key = f"analysis:{a.name}"
                timings[key] = timings.get(key, 0.0) + time.perf_counter() - t0
        files: list[str] = []
        skipped: list[str] = []
        if outputs:
            files = write_outputs(tmp, wf, machines, results, timings, skipped)
        status = overall_status(results, expected_verdicts(wf))
        if skipped and status == "ok":
            status = "partial"
        timings["total"] = time.perf_counter() - t_start
        store = outputs and wf.spec.outputs.exports.store and _can_store(skipped)
        if outputs:
            files += [REPORT] + ([STORE] if store else [])
        manifest = _manifest(wf, base, results, timings, status, files, mobility)
        manifest["skipped_outputs"] = skipped
        (tmp / "manifest.json").write_text(json.dumps(manifest, indent=2, default=str))
        if store:
            with stage(f"{wf.name}: results store"):
                write_store(tmp / STORE, run_rows(wf, machines, results), manifest)
        if outputs:  # from what the run wrote: `pipeline report` makes it again the same
            with stage(f"{wf.name}: report"):
                write_report(tmp)
        kept = wf.spec.outputs.history
        replace_dir(tmp, final, history_slot(final) if kept.runs and final.exists() else None)
        prune_history(final, kept.runs, kept.mb)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return RunResult(wf, final, base, machines, results, manifest)


def _can_store(skipped: list[str]) -> bool:
    """Whether pyarrow is there for the results store (else a note in ``skipped``)."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        note = f"exports: {STORE}: needs pyarrow (pip install 'flexmech-pipeline[study]')"
        logger.warning(note)
        skipped.append(note)
        return False
    return True


def _mobility(wf: Workflow, m: Machine) -> dict:
    """The machine's mobility at its start for the manifest ({"loops", "dof",
    "redundant"}; dof None where it could not be determined), naming the redundant closure
    constraints once per run (as ADAMS does at verification): kept by the DAE
    formulation, their reactions are not unique (minimum-norm ones are reported)."""
    from pipeline.kinematics import dof_report

    loops = len(m.mechanism.topology.loops)
    if not loops:
        return {"loops": 0, "dof": m.mechanism.n, "redundant": []}
    try:
        rep = dof_report(m.mechanism, m.q0, list(m.system.drivers))
    except PipelineError as exc:  # a singular start: the analyses will say so
        logger.warning("%s: mobility not determined at the start: %s", wf.name, exc)
        return {"loops": loops, "dof": None, "redundant": []}
    if rep.redundant:
        logger.warning("%s: %d redundant closure constraints (kept; their reactions are "
                       "minimum-norm): %s", wf.name, len(rep.redundant),
                       ", ".join(rep.redundant))
    return {"loops": loops, "dof": rep.dof, "redundant": list(rep.redundant)}


def expected_verdicts(wf: Workflow) -> dict[tuple[str, str], str]:
    """{(analysis, case label): the verdict the case expects} (``expect:``, default ok)."""
    return {(a.name, c.label): c.expect for a in wf.spec.analyses for c in a.cases}


def overall_status(results: dict, expected: dict | None = None) -> str:
    """"partial" if any analysis stopped, else "suspect" if any case ended other than it
    expects (``expected``: {(analysis, case): verdict}, default "ok"), else "ok".

    results : {analysis name: [AnalysisResult, ...]}. A comparison case that expects
    "suspect" and ends "ok" makes the run suspect: it no longer shows what it was kept for.
    """
    expected = expected or {}
    verdicts = set()
    for name, rs in results.items():
        for r in rs:
            want = expected.get((name, r.case), "ok")
            verdicts.add("ok" if r.verdict == want else
                         "partial" if r.verdict == "partial" else "suspect")
    return next((v for v in ("partial", "suspect") if v in verdicts), "ok")


def _manifest(wf: Workflow, base: Machine, results, timings, status, files,
              mobility: dict) -> dict:
    analyses = {}
    expected = expected_verdicts(wf)
    for name, rs in results.items():
        analyses[name] = [{"case": r.case, "type": r.type, "success": r.success,
                           "verdict": r.verdict,
                           "expected": expected.get((name, r.case), "ok"),
                           "message": r.message,
                           "warnings": list(r.warnings), "outputs": len(r.t),
                           "seconds": round(r.timings.get("total", 0.0), 3),
                           **({"error_estimate_seconds":
                               round(r.extra["error_estimate_seconds"], 3)}
                              if "error_estimate_seconds" in r.extra else {})} for r in rs]
    links = {name: {"artifact": p.reduced.meta.get("input_hash", "")[:12], "cache": p.cache,
                    "modes": list(p.modes),
                    "frequencies_hz": [float(p.reduced.frequencies_hz[i]) for i in p.modes]}
             for name, p in base.parts.items()}
    return {"workflow": str(wf.path), "name": wf.name, "status": status,
            "input_hash": wf.input_hash(), "quick": wf.quick,
            "overrides": [[p, v] for p, v in wf.overrides], "versions": versions(),
            "coordinates": list(base.mechanism.coordinates),
            "coordinate_units": [coordinate_unit(c) for c in base.mechanism.coordinates],
            "model": {**mobility, "warnings": list(base.model_warnings),
                      "notes": list(base.model_notes)},
            "links": links,
            "analyses": analyses, "timings_s": {k: round(v, 3) for k, v in timings.items()},
            "files": sorted(files),
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
