"""Benchmark (issue 27): what the hydraulics cost. The shipped front loader lifted through
its valve (workflows/front_loader_hydraulic.yaml, 4 s) against the same machine with the
lift cylinder's stroke prescribed: the hydraulic run's own stroke history, read back as a
spline table, the cylinder element removed. Both at the same 2 ms step, interleaved
repeats, wall seconds of the lift analysis -> seconds per simulated second, their ratio
(goal: at most 2x) and the real-time factor (goal: at least 10x). Then the step the oil
stiffness allows: the hydraulic lift at 5, 2 and 1 ms, each with its own error estimate
against the tolerance the workflow asks (rtol 3e-2). Writes
``output/bench/hydraulic_loader.json``. Not a timed test."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from pipeline.core.atomic import atomic_open

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "output" / "bench" / "hydraulic_loader.json"
REPEATS = 5
T_END = 4.0


def _prescribed(text: str, table: str) -> str:
    """The hydraulic workflow's text with the lift cylinder's stroke prescribed by
    ``table`` (a CSV beside it) instead of its hydraulic cylinder: the force element, the
    linearised analysis and the plots of its states go."""
    text = re.sub(r"  - name: lift_cyl .*?\n(?=\nanalyses:)", "", text, flags=re.DOTALL)
    text = text.replace("  TCYL.d: {type: constant", f"  LCYL.d: {{type: table, file: {table}, "
                        "interpolation: spline}\n  TCYL.d: {type: constant")
    text = re.sub(r"  - name: ring .*?\n(?=  - name: lift)", "", text, flags=re.DOTALL)
    text = re.sub(r"\noutputs:.*?\n(?=\nquick:)", "\n", text, flags=re.DOTALL)
    return text.replace("name: front_loader_hydraulic", "name: front_loader_prescribed")


@pytest.mark.bench
def test_bench_hydraulic_against_prescribed_strokes(tmp_path):
    from pipeline.workflow.run import run_workflow

    for sub in ("workflows", "meshes"):
        shutil.copytree(ROOT / sub, tmp_path / sub)
    wf = tmp_path / "workflows"
    hyd_path = wf / "front_loader_hydraulic.yaml"
    cache, out = tmp_path / "links", tmp_path / "out"

    def lift(path, sets=()):
        res = run_workflow(path, out_root=out, cache_dir=cache, outputs=False, sets=list(sets))
        (case,) = res.manifest["analyses"]["lift"]
        return res, case

    res, _ = lift(hyd_path)  # builds the links, compiles
    r = res.result("lift", "")
    i = res.machine.mechanism.index("LCYL.d")
    stroke = np.column_stack([r.t, r.q[:, i]])
    np.savetxt(wf / "lift_stroke.csv", stroke, delimiter=",", header="time_s,length_m",
               comments="", fmt="%.12g")
    pre_path = wf / "front_loader_prescribed.yaml"
    pre_path.write_text(_prescribed(hyd_path.read_text(), "lift_stroke.csv"))
    lift(pre_path)
    runs = []
    for _ in range(REPEATS):
        h = lift(hyd_path)[1]
        p = lift(pre_path)[1]
        assert h["success"] and p["success"], (h["message"], p["message"])
        runs.append({"hydraulic_s": h["seconds"], "prescribed_s": p["seconds"],
                     "verdicts": [h["verdict"], p["verdict"]],
                     "ratio": h["seconds"] / p["seconds"],
                     "hydraulic_real_time_factor": T_END / h["seconds"]})
    steps = []
    for step in (0.005, 0.002, 0.001):
        res, case = lift(hyd_path, (f"analyses.lift.step={step}",))
        steps.append({"step_s": step, "verdict": case["verdict"], "seconds": case["seconds"],
                      "error_over_tolerance": float(res.result("lift", "").extra.get(
                          "error_ratio", np.nan))})
    ratios = [x["ratio"] for x in runs]
    factors = [x["hydraulic_real_time_factor"] for x in runs]
    result = {"machine": "2-core shared machine; wall seconds of the lift analysis",
              "case": "workflows/front_loader_hydraulic.yaml lift, 4 s at h = 2 ms, against "
                      "the same machine with the stroke prescribed (the hydraulic run's "
                      "history as a spline table), same step",
              "runs": runs, "ratio_median": float(np.median(ratios)),
              "ratio_range": [float(min(ratios)), float(max(ratios))],
              "real_time_factor_median": float(np.median(factors)),
              "steps": steps}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(result, fh, indent=1)
    print(json.dumps(result, indent=1))
