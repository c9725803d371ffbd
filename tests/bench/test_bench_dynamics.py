"""Benchmark (a): flexible double pendulum of two real reduced bars, four modes each, 1 s.

Prints wall time, steps, right-hand-side evaluations and time per evaluation
per integrator setting, a cProfile breakdown of one run, and writes
``output/bench/dynamics.json``. Not a timed test.
"""

from __future__ import annotations

import cProfile
import io
import json
import pstats
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
from eom_models import flexible_double_pendulum, reduced_bar_pendulum

from pipeline.core.atomic import atomic_open
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "dynamics.json"
RUNS = [("DOP853", 1e-6), ("DOP853", 1e-8), ("Radau", 1e-6)]


def _profile(system, q0):
    pr = cProfile.Profile()
    pr.enable()
    simulate(system, q0, q0, (0.0, 0.2), np.linspace(0, 0.2, 21), rtol=1e-8, atol=1e-8,
             progress=False)
    pr.disable()
    st = pstats.Stats(pr)
    total = sum(v[3] for k, v in st.stats.items() if k[2] == "reduced_state") or 1.0
    shares = {}
    for (file, _, func), v in st.stats.items():
        if func in ("inertia_terms", "equation_terms", "evaluate_tree",
                    "closure", "elastic_forces", "solve"):
            shares[f"{Path(file).stem}.{func}"] = round(v[3] / total, 3)
    buf = io.StringIO()
    pstats.Stats(pr, stream=buf).sort_stats("tottime").print_stats(8)
    return shares, buf.getvalue()


def _stiff_comparison():
    """Explicit vs implicit on a stiff point-cloud pendulum (modes 0.5-4 kHz, zeta 2 %)."""
    s = flexible_double_pendulum(n_modes=3, k_scale=1e7, zeta=0.02).system
    q0 = np.zeros(s.mechanism.n)
    rows = []
    for method in ("DOP853", "Radau", "BDF"):
        r = simulate(s, q0, q0, (0.0, 0.1), np.linspace(0, 0.1, 11), method=method, rtol=1e-6,
                     atol=1e-8, progress=False)
        rows.append({"method": method, "success": r.success, "wall_s": r.timings["total"],
                     "steps": r.n_steps, "rhs_evaluations": r.n_rhs})
        print("stiff case:", rows[-1])
    return {"case": "cloud double pendulum, 3 modes each, k_scale 1e7, zeta 0.02, 0.1 s, "
                    "rtol 1e-6, atol 1e-8", "runs": rows}


@pytest.mark.bench
@pytest.mark.gmsh
def test_bench_flexible_double_pendulum(tmp_path):
    system, red = reduced_bar_pendulum(tmp_path, n_modes=4)
    q0 = np.zeros(system.mechanism.n)
    rows = []
    for method, tol in RUNS:
        r = simulate(system, q0, q0, (0.0, 1.0), np.linspace(0, 1, 101), method=method,
                     rtol=tol, atol=tol, progress=False)
        E = r.energies["total"]
        rows.append({"method": method, "rtol": tol, "atol": tol, "success": r.success,
                     "wall_s": r.timings["total"], "integrate_s": r.timings["integrate"],
                     "steps": r.n_steps, "rhs_evaluations": r.n_rhs,
                     "ms_per_rhs": 1e3 * r.timings["integrate"] / max(r.n_rhs, 1),
                     "energy_drift_rel": float(np.abs(E - E[0]).max()
                                               / np.abs(r.energies["kinetic"]).max()),
                     "max_abs_eta": float(np.abs(r.q[:, 2:]).max())})
        print(rows[-1])
    stiff = _stiff_comparison()
    shares, table = _profile(system, q0)
    print("share of reduced_state time:", shares)
    print(table)
    report = {"case": "flexible double pendulum, 2 reduced Al bars 1.0 x 0.03 x 0.015 m, "
                      "4 modes each, released horizontal, 1 s",
              "frequencies_hz": red.frequencies_hz.tolist(), "runs": rows,
              "profile_share_of_rhs": shares,
              "stiff_case": stiff}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT) as fh:
        json.dump(report, fh, indent=2)
    assert all(r["success"] for r in rows)
