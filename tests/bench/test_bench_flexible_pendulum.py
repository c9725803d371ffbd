"""Benchmark (b) of the closed-loop issue: the flexible pendulum, side by side with Exudyn.

The aluminium bar 0.4 x 0.008 x 0.004 m (meshes/al_bar.yaml, P2 tetrahedra), 8 modes clamped
at its pinned root, released horizontal under gravity, 1 s (tests/bench/pendulum_peer.py).
Both codes integrate with generalised-alpha (rho_inf 0.8). For each, the largest step of
``STEPS`` whose tip positions (101 outputs) stay within ``TOL`` of that code's own converged
run (the same method at 10 us) is timed, runs interleaved, in CPU seconds; the ratio is ours
over Exudyn's. Each code is compared with its own converged run: the reduced models differ
(Exudyn's mass-proportional gravity ignores the deformed centre of mass; ours is exact), and
the two converged tips are printed side by side as a check that both model the same bar.

Prints the figures and writes ``output/bench/flexible_pendulum.json``. Exudyn (installed from
PyPI, a benchmark peer only) is skipped cleanly when absent. Not a timed test.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import pendulum_peer as P

from pipeline.core.atomic import atomic_open
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "flexible_pendulum.json"
T_END, N_OUT, TOL, RHO = 1.0, 101, 1e-5, 0.8
STEPS = (2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4)
CONVERGED = 1e-5
REPEATS = 5


def _ours(system, h):
    """(CPU s, tip positions (N_OUT, 3), verdict) of one run at step h."""
    n = system.mechanism.n
    te = np.linspace(0.0, T_END, N_OUT)
    c0 = time.process_time()
    r = simulate(system, np.zeros(n), np.zeros(n), (0.0, T_END), te,
                 method="generalized_alpha",
                 error_estimate=False, step=h, rho_inf=RHO, progress=False)
    cpu = time.process_time() - c0
    return cpu, P.tip_positions(system, r.q), r.verdict


def _peer(model, root, h):
    """(CPU s, tip positions (N_OUT, 3)) of Exudyn's run at step h, or None."""
    out = P.exudyn_run(model, root, T_END, h, N_OUT, rho_inf=RHO)
    return None if out is None else (out[0], np.asarray(out[2])[:N_OUT, 1:4])


def _largest_step(run, label):
    """(step, error of every step tried, converged tips) for ``run(h) -> (cpu, tips, ...)``."""
    ref = run(CONVERGED)[1]
    errors, chosen = {}, None
    for h in STEPS:
        err = float(np.abs(run(h)[1] - ref).max())
        errors[f"{h:g}"] = err
        print(f"{label}: h = {h:g} s, tip error {err:.3g} m")
        if err <= TOL and chosen is None:
            chosen = h
    return chosen, errors, ref


@pytest.mark.bench
def test_bench_flexible_pendulum(tmp_path):
    red, model, root = P.fe_and_reduced(tmp_path, mesh_size=None)
    system = P.pipeline_model(red)
    _ours(system, 1e-3)  # the compiled kernels load from numba's cache (or compile) once
    report = {"case": "aluminium bar 0.4 x 0.008 x 0.004 m, P2 mesh of meshes/al_bar.yaml "
                      f"({model.n_dof} DOF), 8 modes clamped at the pinned root, released "
                      "horizontal under gravity, 1 s, generalised-alpha rho_inf 0.8, tip "
                      f"error <= {TOL:g} m against each code's own run at {CONVERGED:g} s",
              "machine": "2-core shared machine; CPU seconds (process_time), interleaved runs",
              "frequencies_hz": [float(f) for f in red.frequencies_hz]}
    h_ours, err_ours, ref_ours = _largest_step(lambda h: _ours(system, h), "ours")
    report["ours"] = {"step_s": h_ours, "tip_errors_m": err_ours}
    peer = _peer(model, root, 1e-3)
    if peer is not None:
        h_peer, err_peer, ref_peer = _largest_step(lambda h: _peer(model, root, h), "Exudyn")
        report["exudyn"] = {"step_s": h_peer, "tip_errors_m": err_peer}
        report["converged_tips_differ_m"] = float(np.abs(ref_ours - ref_peer).max())
    rows = []
    for _ in range(REPEATS):
        ours = _ours(system, h_ours)
        row = {"ours_cpu_s": ours[0], "ours_verdict": ours[2]}
        if peer is not None:
            theirs = _peer(model, root, h_peer)
            row.update(exudyn_cpu_s=theirs[0], ratio=ours[0] / theirs[0])
        rows.append(row)
        print(row)
    report["runs"] = rows
    report["ours_cpu_s_median"] = float(np.median([r["ours_cpu_s"] for r in rows]))
    if peer is not None:
        report["exudyn_cpu_s_median"] = float(np.median([r["exudyn_cpu_s"] for r in rows]))
        report["ratio_median"] = float(np.median([r["ratio"] for r in rows]))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT) as fh:
        json.dump(report, fh, indent=2)
    print(json.dumps(report, indent=1))
    assert all(r["ours_verdict"] == "ok" for r in rows)
    assert h_ours is not None, err_ours
