"""Benchmark (issue 27): what the hydraulics cost, on the two shipped machines driven
through valves:

* the front loader's lift (workflows/front_loader_hydraulic.yaml, 4 s at 2 ms);
* the excavator's dig cycle with its flexible boom (workflows/excavator_hydraulic.yaml,
  6 s at 1 ms).

Each against the same machine with its cylinders' strokes prescribed: the hydraulic run's
own stroke histories, read back as spline tables, the cylinder elements removed (the
workflow's YAML edited as data, not as text). Both at the same step, interleaved repeats,
wall seconds of the analysis (its fixed-step error estimate included, as a user waits for
it) -> seconds per simulated second, their ratio (goal: at most 2x) and the real-time
factor (goal: at least 10x). Then the step the oil stiffness allows: the hydraulic and the
prescribed runs at several steps, each with its own error estimate against the tolerance
the workflow asks. Writes ``output/bench/hydraulics.json``. Not a timed test."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.core.atomic import atomic_open

pytestmark = [pytest.mark.bench, pytest.mark.gmsh]

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "output" / "bench" / "hydraulics.json"
REPEATS = 5

#: workflow, its analysis, the stroke coordinate of each hydraulic cylinder, steps tried
MACHINES = {
    "front_loader": ("front_loader_hydraulic", "lift", {"lift_cyl": "LCYL.d"},
                     (0.005, 0.002, 0.001)),
    "excavator": ("excavator_hydraulic", "dig", {"boom_cyl": "BCYL.d", "stick_cyl": "SCYL.d"},
                  (0.0025, 0.002, 0.001, 0.0005)),
}


def prescribed(data: dict, analysis: str, tables: dict[str, str]) -> dict:
    """The workflow ``data`` (its YAML as loaded) with the hydraulic cylinders named in
    ``tables`` removed and their stroke coordinates driven by the CSV tables given
    (coordinate -> file beside the workflow): that analysis only, no outputs."""
    data = dict(data, name=data["name"] + "_prescribed")
    data["forces"] = [f for f in data["forces"] if f["name"] not in tables]
    data["drivers"] = {**data.get("drivers", {}),
                       **{c: {"type": "table", "file": f, "interpolation": "spline"}
                          for c, f in tables.values()}}
    driven = {c for c, _ in tables.values()}
    initial = dict(data.get("initial", {}))  # a copy: ``data`` is left as it was read
    for group in ("coordinates", "velocities"):  # a driven coordinate starts on its table
        if group in initial:
            initial[group] = {k: x for k, x in initial[group].items() if k not in driven}
    if initial:
        data["initial"] = initial
    data["analyses"] = [a for a in data["analyses"] if a["name"] == analysis]
    for key in ("outputs", "quick"):
        data.pop(key, None)
    return data


@pytest.mark.parametrize("machine", sorted(MACHINES))
def test_bench_hydraulic_against_prescribed_strokes(machine, tmp_path):
    from pipeline.workflow.run import run_workflow
    from pipeline.workflow.yaml_io import load_yaml

    name, analysis, cylinders, steps = MACHINES[machine]
    for sub in ("workflows", "meshes"):
        shutil.copytree(ROOT / sub, tmp_path / sub)
    wf = tmp_path / "workflows"
    hyd_path = wf / f"{name}.yaml"
    cache, out = ROOT / "output" / "links", tmp_path / "out"

    def run(path, sets=()):
        res = run_workflow(path, out_root=out, cache_dir=cache, outputs=False, sets=list(sets))
        (case,) = res.manifest["analyses"][analysis]
        return res, case

    data = load_yaml(hyd_path)[0]  # as the workflow reads it (a key "on" stays "on")
    (spec,) = (a for a in data["analyses"] if a["name"] == analysis)
    t_end, h0 = float(spec["t_end"]), float(spec["step"])
    # the strokes at every step (the outputs' spacing would alias the oil columns' ringing
    # into the tables), run on past the end: a spline table is clamped (at rest) at its
    # last knot, and a stroke still moving there would stop within one knot interval.
    # This run also builds (or finds) the links and compiles
    longer = t_end + 0.25
    res, _ = run(hyd_path, (f"analyses.{analysis}.t_end={longer}",
                            f"analyses.{analysis}.outputs={round(longer / h0) + 1}"))
    r = res.result(analysis, "")
    tables = {}
    for cyl, coord in cylinders.items():
        csv = f"{cyl}_stroke.csv"
        stroke = np.column_stack([r.t, r.q[:, r.coordinates.index(coord)]])
        np.savetxt(wf / csv, stroke, delimiter=",", header="time_s,length_m", comments="",
                   fmt="%.12g")
        tables[cyl] = (coord, csv)
    pre_path = wf / f"{name}_prescribed.yaml"
    pre_path.write_text(yaml.safe_dump(prescribed(data, analysis, tables), sort_keys=False))
    _, p = run(pre_path)
    assert p["verdict"] == "ok", (p["message"], p["warnings"])
    runs = []
    for _ in range(REPEATS):
        h = run(hyd_path)[1]
        p = run(pre_path)[1]
        assert h["success"] and p["success"], (h["message"], p["message"])
        runs.append({"hydraulic_s": h["seconds"], "prescribed_s": p["seconds"],
                     "verdicts": [h["verdict"], p["verdict"]],
                     "ratio": h["seconds"] / p["seconds"],
                     "hydraulic_real_time_factor": t_end / h["seconds"]})
        print(runs[-1])
    scan = []
    for step in steps:
        row = {"step_s": step}
        for label, path in (("hydraulic", hyd_path), ("prescribed", pre_path)):
            res, case = run(path, (f"analyses.{analysis}.step={step}",))
            row[label] = {"verdict": case["verdict"], "seconds": case["seconds"],
                          "error_over_tolerance": float(res.result(analysis, "").extra.get(
                              "error_ratio", np.nan))}
        scan.append(row)
        print(row)
    ratios = [x["ratio"] for x in runs]
    factors = [x["hydraulic_real_time_factor"] for x in runs]
    result = {"machine": f"{os.cpu_count()}-core shared machine; wall seconds of the "
                         f"analysis, its error estimate included",
              "case": f"workflows/{name}.yaml {analysis}, {t_end:g} s at its own step, "
                      "against the same machine with the strokes prescribed (the hydraulic "
                      "run's histories as spline tables), same step",
              "runs": runs, "ratio_median": float(np.median(ratios)),
              "ratio_range": [float(min(ratios)), float(max(ratios))],
              "real_time_factor_median": float(np.median(factors)),
              "real_time_factor_range": [float(min(factors)), float(max(factors))],
              "steps": scan}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(OUT.read_text()) if OUT.exists() else {}
    with atomic_open(OUT, "w") as fh:
        json.dump({**old, machine: result}, fh, indent=1)
    print(json.dumps(result, indent=1))
