"""Benchmark: how a step's cost grows with the bodies of an open chain (issue 25's goal:
N = 64 within 1.5x Exudyn, growth within N^1.5). The planar N-bar chain of
``chain_peer.py`` released from the horizontal, 1 s at a fixed 1 ms generalised-alpha
step (rho_inf 0.8) for N = 2 ... 64; the pipeline and Exudyn 1.13 (when installed)
interleaved, 3 pairs per N, CPU microseconds per step; each run's first-bar angle at the
end against a reference (the pipeline at 1/8 of the step, tight tolerances) ->
``output/bench/open_chain.json``. Not a timed test."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import chain_peer as C

from pipeline.core.atomic import atomic_open
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "open_chain.json"
SIZES = (2, 4, 8, 16, 32, 64)
T_END, STEP, PAIRS = 1.0, 1e-3, 3


def _ours(system, n, step=STEP, tol=(1e-6, 1e-8)):
    q0 = np.zeros(n)
    c0 = time.process_time()
    r = simulate(system, q0, q0, (0.0, T_END), method="generalized_alpha", step=step,
                 progress=False, error_estimate=False, rtol=tol[0], atol=tol[1])
    cpu = time.process_time() - c0
    assert r.success, r.message
    return cpu, float(r.q[-1, 0]), r


@pytest.mark.bench
def test_bench_open_chain_scaling():
    rows = []
    for n in SIZES:
        system = C.pipeline_model(n)
        _ours(system, n)  # kernels loaded once
        ref = _ours(system, n, STEP / 8, (1e-9, 1e-11))[1]
        steps = round(T_END / STEP)
        ours, peer, ratio = [], [], []
        for _ in range(PAIRS):
            cpu, angle, r = _ours(system, n)
            ours.append(1e6 * cpu / steps)
            other = C.exudyn_run(n, T_END, STEP)
            if other is not None:
                peer.append(1e6 * other[0] / steps)
                ratio.append(ours[-1] / peer[-1])
        row = {"n": n, "us_per_step": float(np.median(ours)),
               "evaluations_per_step": float(r.step_stats.get("evaluations", np.nan)) / steps,
               "error_rad": abs(angle - ref)}
        if peer:
            row.update({"exudyn_us_per_step": float(np.median(peer)),
                        "ratio_median": float(np.median(ratio)),
                        "ratio_range": [min(ratio), max(ratio)],
                        "exudyn_error_rad": abs(other[1] - ref)})
        rows.append(row)
        print(row)
    us = np.array([r["us_per_step"] for r in rows])
    growth = np.log2(us[1:] / us[:-1])
    out = {"machine": "2-core shared machine, CPU seconds (process_time)",
           "case": f"planar N-bar open chain from the horizontal, {T_END} s, generalised-alpha "
                   f"{STEP} s, rho_inf 0.8", "rows": rows,
           "growth_exponent_per_doubling": growth.tolist()}
    print(json.dumps(out, indent=1))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT) as fh:
        json.dump(out, fh, indent=2)
