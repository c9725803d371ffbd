"""Benchmark: what recording the outputs of a dynamic run costs, as a share of the run.

Two runs, each with a sparse and a dense output grid:

* a slider-crank (closed loop, DAE formulation, generalised-alpha, h = 1 ms) over 10 s,
  outputs every 10 ms and every 1 ms (every step);
* the double pendulum's flexible bars (open chain, partitioned formulation, DOP853) over
  2 s, 401 and 2001 outputs.

Figures: the solver's own split of its wall time (``timings['output']`` against
``timings['total']``) and the seconds per output; for the fixed-step run, which records
its outputs inside the compiled march (their cost is in ``timings['integrate']``), the
CPU time against the same run recording its two ends only, 5 interleaved pairs ->
``output/bench/recording.json``. Goal (issue 13): recording < 5 % of a run at the
shipped output density. Not a timed test.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))

from pipeline.core.atomic import atomic_open
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "recording.json"


def _slider_crank():
    from dyn2_models import rigid_bar
    from kin_models import slider_crank

    from pipeline.dynamics import BodyMass, System
    from pipeline.kinematics.initial import initial_positions

    m = slider_crank(0.2, 0.6, 0.0, theta0=0.3)
    s = System(m, {"crank": rigid_bar(1.0, 0.2), "rod": rigid_bar(2.0, 0.6),
                   "slider": BodyMass.rigid(3.0, [0, 0, 0], 0.01 * np.eye(3))},
               gravity=[0.0, -9.81, 0.0])
    q0 = initial_positions(m, m.q_initial, given={"crank.theta": 0.3})
    qd0 = np.zeros(m.n)
    qd0[0] = 20.0
    return s, q0, qd0


def _pendulum():
    from pipeline.workflow.build import build_machine
    from pipeline.workflow.load import load_workflow

    wf = load_workflow(Path(__file__).resolve().parents[2] / "workflows" / "double_pendulum.yaml")
    m = build_machine(wf, Path(__file__).resolve().parents[2] / "output" / "links")
    return m.system, m.q0, m.qd0


def _share(r) -> dict:
    return {"outputs": int(r.t.size), "steps": int(r.n_steps),
            "total_s": r.timings["total"], "output_s": r.timings["output"],
            "share": r.timings["output"] / r.timings["total"],
            "ms_per_output": 1e3 * r.timings["output"] / max(r.t.size, 1),
            "verdict": r.verdict}


@pytest.mark.bench
def test_bench_recording_share():
    report = {"machine": "2-core shared VM, no GPU"}
    s, q0, qd0 = _slider_crank()
    kw = {"method": "generalized_alpha", "error_estimate": False, "step": 1e-3,
          "progress": False}
    simulate(s, q0, qd0, (0.0, 0.2), **kw)  # compile
    for every in (0.01, 0.001):
        te = np.linspace(0.0, 10.0, round(10.0 / every) + 1)
        extra = []
        for _ in range(5):
            c0 = time.process_time()
            r = simulate(s, q0, qd0, (0.0, 10.0), te, **kw)
            c1 = time.process_time()
            simulate(s, q0, qd0, (0.0, 10.0), [0.0, 10.0], **kw)
            c2 = time.process_time()
            extra.append(((c1 - c0) - (c2 - c1)) / (c1 - c0))
        report[f"slider_crank_every_{every * 1e3:g}ms"] = {
            **_share(r), "recording_share_cpu_median": float(np.median(extra)),
            "recording_share_cpu_range": [min(extra), max(extra)]}
    s, q0, qd0 = _pendulum()
    for n in (401, 2001):
        r = simulate(s, q0, qd0, (0.0, 2.0), np.linspace(0.0, 2.0, n), method="DOP853",
                     rtol=1e-7, atol=1e-9, progress=False)
        report[f"double_pendulum_{n}_outputs"] = _share(r)
    for k, v in report.items():
        print(k, v)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(report, fh, indent=1)
    assert all(v["verdict"] == "ok" for k, v in report.items() if k != "machine")
