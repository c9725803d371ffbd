"""Benchmark: what a fixed step's error estimate costs (issue 24's goal: under 10 % of its
stage). The loader's 10 s lift with two flexible links at 10 ms (1001 outputs), from its
static equilibrium: the run's own wall time, the estimate's (the same motion at twice the
step, positions recorded only) and their ratio, over interleaved repeats ->
``output/bench/error_estimate.json``. Not a timed test."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
from loader_flex_model import build_flexible_loader, reduce_links

from pipeline.core.atomic import atomic_open
from pipeline.dynamics import static_equilibrium
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "error_estimate.json"
REPEATS = 5


@pytest.mark.bench
def test_bench_error_estimate(tmp_path):
    reduced = reduce_links(tmp_path, arm_size=0.02, link_size=0.015, arm_modes=2, link_modes=1)
    system, q_ref = build_flexible_loader(reduced, t_lift=10.0)
    q0 = static_equilibrium(system, q_ref).q
    t = np.linspace(0.0, 10.0, 1001)
    kw = {"method": "generalized_alpha", "step": 0.01, "rtol": 1e-6, "atol": 1e-8,
          "progress": False}
    simulate(system, q0, np.zeros_like(q0), (0.0, 0.02), [0.0, 0.02], **kw)  # compile
    runs = []
    for _ in range(REPEATS):
        r = simulate(system, q0, np.zeros_like(q0), (0.0, 10.0), t, **kw)
        assert r.success and "error_ratio" in r.step_stats
        run, est = r.timings["total"], r.step_stats["error_seconds"]
        runs.append({"run_s": run, "output_s": r.timings["output"], "estimate_s": est,
                     "estimate_over_run": est / run,
                     "estimate_over_integration": est / (run - r.timings["output"]),
                     "error_ratio": r.step_stats["error_ratio"]})
    shares = [x["estimate_over_run"] for x in runs]
    out = {"machine": "2-core shared machine; wall seconds",
           "case": "loader 10 s lift, two flexible links (2 + 1 modes), generalised-alpha "
                   "h = 10 ms, rtol 1e-6, 1001 outputs, from the static equilibrium",
           "runs": runs, "estimate_over_run_median": float(np.median(shares)),
           "estimate_over_run_range": [float(min(shares)), float(max(shares))]}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps(out, indent=1))
