"""Benchmark: position + velocity + acceleration analysis of the front-end loader
over a 1000-point lift stroke (both cylinders driven). Prints the time per
configuration and where it goes; writes output/bench/kinematics.json."""

from __future__ import annotations

import cProfile
import json
import pstats
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))

import loader_geometry as geo
from loader_model import build_loader

from pipeline.core.atomic import atomic_open
from pipeline.kinematics import sweep
from pipeline.kinematics.drivers import SmoothStep

N_POINTS, T_END, REPEATS = 1000, 4.0, 3
OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "kinematics.json"


def _setup():
    mech, q0 = build_loader()
    lift = geo.CYLINDERS["lift"]
    drivers = {"LCYL.d": SmoothStep(0.0, T_END, lift.min_length, lift.max_length),
               "TCYL.d": SmoothStep(0.0, T_END, geo.REFERENCE_TILT_LENGTH,
                                    geo.CYLINDERS["tilt"].min_length)}
    return mech, q0, drivers, np.linspace(0.0, T_END, N_POINTS)


def _breakdown(mech, q0, drivers, t) -> dict[str, float]:
    """Share of the sweep's time per stage (cProfile; relative figures only)."""
    prof = cProfile.Profile()
    prof.enable()
    sweep(mech, drivers, t, q0)
    prof.disable()
    st = pstats.Stats(prof).stats
    total = max(v[3] for k, v in st.items() if k[2] == "sweep")

    def cum(name, caller=None, where="pipeline"):
        out = 0.0
        for (file, _, fn), (_, _, _, ct, callers) in st.items():
            if fn != name or where not in file:
                continue
            if caller is None:
                out += ct
            else:
                out += sum(c[3] for (_, _, cf), c in callers.items() if cf == caller)
        return out

    newton_closure = cum("closure", "_newton")
    parts = {
        "newton: closure residual + jacobian": newton_closure,
        "newton: linear solve + line search logic": cum("_newton") - newton_closure,
        "gamma (rate pass)": cum("closure", "sweep"),
        "velocity + acceleration solves": cum("solve_velocity") + cum("solve_acceleration"),
        "conditioning monitor (normalise + svd)": cum("normalised_jacobian", "sweep")
        + cum("svd", "sweep", where="linalg"),
        "drivers": cum("_driver_state"),
    }
    parts["other (bookkeeping)"] = total - sum(parts.values())
    return {k: v / total for k, v in parts.items()}


@pytest.mark.bench
def test_bench_loader_kinematic_sweep():
    mech, q0, drivers, t = _setup()
    sweep(mech, drivers, t[:20], q0)  # warm up
    times, res = [], None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        res = sweep(mech, drivers, t, q0)
        times.append(time.perf_counter() - t0)
    assert res.success, res.message
    per_config_ms = 1e3 * min(times) / N_POINTS
    shares = _breakdown(mech, q0, drivers, t)
    result = {
        "mechanism": "front-end loader (tests/kinematics/loader_geometry.py)",
        "coordinates": mech.n, "loops": len(mech.topology.loops), "links": len(mech.links),
        "points": N_POINTS, "repeats": REPEATS,
        "ms_per_configuration_best": per_config_ms,
        "ms_per_configuration_all": [1e3 * x / N_POINTS for x in times],
        "goal_ms": 1.0,
        "newton_iterations_histogram": np.bincount(res.newton_iterations).tolist(),
        "reselections": len(res.reselections),
        "time_shares": shares,
    }
    with atomic_open(OUT, "w") as fh:
        json.dump(result, fh, indent=2)
    print(f"\nloader sweep: {per_config_ms:.3f} ms per configuration "
          f"(position + velocity + acceleration, best of {REPEATS}; goal 1 ms)")
    for k, v in shares.items():
        print(f"  {k:42s} {100 * v:5.1f} %")
