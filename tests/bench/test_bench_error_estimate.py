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


LOADER_OUT = OUT.with_name("error_estimate_loader_workflow.json")


@pytest.mark.bench
def test_bench_error_estimate_in_the_shipped_loader_workflow(tmp_path):
    """The goal's own case: the shipped front loader's lift (2 s at 5 ms, 101 outputs,
    from its static equilibrium), as ``pipeline run workflows/front_loader.yaml`` runs it.
    Per repeat: the estimate's seconds over the lift case's and over the analysis stage's
    (every analysis of the workflow); results only, no plots."""
    from pipeline.workflow.run import run_workflow

    root = Path(__file__).resolve().parents[2]
    cache = tmp_path / "links"
    runs = []
    for k in range(REPEATS + 1):
        res = run_workflow(root / "workflows" / "front_loader.yaml", out_root=tmp_path / "out",
                           cache_dir=cache, outputs=False)
        lift = res.manifest["analyses"]["lift"]
        stage = sum(c["seconds"] for cases in res.manifest["analyses"].values() for c in cases)
        est = sum(c["error_estimate_seconds"] for c in lift)
        case = sum(c["seconds"] for c in lift)
        if k:  # the first run builds the links and compiles
            runs.append({"lift_case_s": case, "estimate_s": est, "analysis_stage_s": stage,
                         "estimate_over_case": est / case, "estimate_over_stage": est / stage})
    shares = [x["estimate_over_case"] for x in runs]
    stages = [x["estimate_over_stage"] for x in runs]
    out = {"machine": "2-core shared machine; wall seconds",
           "case": "workflows/front_loader.yaml, analysis 'lift' (generalised-alpha h = 5 ms, "
                   "2 s, 101 outputs, static start); the stage is every analysis of the run",
           "runs": runs,
           "estimate_over_case_median": float(np.median(shares)),
           "estimate_over_case_range": [float(min(shares)), float(max(shares))],
           "estimate_over_stage_median": float(np.median(stages)),
           "estimate_over_stage_range": [float(min(stages)), float(max(stages))]}
    with atomic_open(LOADER_OUT, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps(out, indent=1))
