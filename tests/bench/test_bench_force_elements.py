"""Benchmark: what a force element's compiled form saves. The flexible four-bar with one
element of every compiled kind (tests/solver/test_compiled_step.py, ``_every_kind``),
0.5 s at a fixed 1 ms generalised-alpha step, CPU microseconds per step with the compiled
kernels and with the same elements as classes without a compiled form (a user's own
elements: the compiled step calls their numpy oracle back), interleaved pairs ->
``output/bench/force_elements.json``. Not a timed test."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "solver"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
import test_compiled_step as T

from pipeline.core.atomic import atomic_open
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "force_elements.json"
PAIRS = 5


def _us_per_step(system, q0, qd0) -> float:
    c0 = time.process_time()
    r = simulate(system, q0, qd0, (0.0, 0.5), method="generalized_alpha", step=1e-3,
                 progress=False, error_estimate=False, rtol=1e-4, atol=1e-6)
    assert r.success
    return 1e6 * (time.process_time() - c0) / r.n_steps


@pytest.mark.bench
def test_bench_compiled_force_elements():
    from pipeline.dynamics import System

    system, q0, qd0 = T._every_kind()
    users = System(system.mechanism, system.bodies, system.gravity,
                   forces=tuple(T._in_python(f) for f in system.forces))
    _us_per_step(system, q0, qd0)  # kernels loaded or compiled once
    _us_per_step(users, q0, qd0)
    rows = []
    for _ in range(PAIRS):
        fast = _us_per_step(system, q0, qd0)
        slow = _us_per_step(users, q0, qd0)
        rows.append({"compiled_us_per_step": fast, "called_back_us_per_step": slow,
                     "ratio": slow / fast})
    ratios = [r["ratio"] for r in rows]
    out = {"machine": "2-core shared machine, CPU seconds (process_time)",
           "case": "flexible four-bar (2 modes) with one force element of every compiled "
                   "kind (9 elements), 0.5 s, generalised-alpha 1 ms; against the same "
                   "elements called back in Python", "runs": rows,
           "ratio_median": float(np.median(ratios)), "ratio_range": [min(ratios),
                                                                     max(ratios)]}
    print(json.dumps(out, indent=1))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT) as fh:
        json.dump(out, fh, indent=2)
