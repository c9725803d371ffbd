"""Benchmark: a 16-case design study (the mobile crane's release at 16 luff angles, quick
mode) as a plain in-process loop, on a local Dask cluster of 1 worker and of 2 workers.
Interleaved repeats (the machine is shared). Prints and writes output/bench/study.json:
wall seconds, the speed-up of 2 workers over 1 (goal >= 0.8 x 2), and the overhead per
case of the distributed path over the plain loop (cluster start included)."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import pytest

from pipeline.core.atomic import atomic_open

pytestmark = [pytest.mark.bench, pytest.mark.gmsh]

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "output" / "bench" / "study.json"
ANGLES = [round(-0.5 - 0.05 * k, 3) for k in range(16)]


def test_bench_study(tmp_path):
    pytest.importorskip("distributed")
    from pipeline.study.engine import run_case, run_study
    from pipeline.workflow import build_machine, load_workflow

    sys.path.insert(0, str(ROOT / "tests" / "study"))
    from luff_study import write_luff_study

    study = write_luff_study(tmp_path / "luff.yaml",
                             f"grid: {{drivers.LUFF.theta.value: {ANGLES}}}")
    links = tmp_path / "links"
    base = ROOT / "workflows" / "mobile_crane.yaml"
    build_machine(load_workflow(base, quick=True), links)  # warm link cache
    figures: dict[str, list[float]] = {"loop": [], "1 worker": [], "2 workers": []}
    for rep in range(2):
        t0 = time.perf_counter()
        for a in ANGLES:
            run_case(str(base), True, {"drivers.LUFF.theta.value": a}, f"{a}", ["release"],
                     str(links), [], [{"name": "peak_heave", "series": "q:HEAVE.d",
                                       "reduce": "peak", "analysis": None}])
        figures["loop"].append(time.perf_counter() - t0)
        for n, key in ((1, "1 worker"), (2, "2 workers")):
            t0 = time.perf_counter()
            res = run_study(study, out_root=tmp_path / f"out{rep}{n}", workers=n,
                            cache_dir=links)
            figures[key].append(time.perf_counter() - t0)
            assert res.ran == 16 and all(r["status"] == "ok" for r in res.rows)
        print({k: [round(x, 2) for x in v] for k, v in figures.items()})
    best = {k: min(v) for k, v in figures.items()}
    summary = {"machine": f"{os.cpu_count()} cores", "cases": 16, "seconds": figures,
               "speedup_2_over_1": best["1 worker"] / best["2 workers"],
               "overhead_per_case_s_1_worker": (best["1 worker"] - best["loop"]) / 16}
    print(json.dumps(summary, indent=2))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(summary, fh, indent=2)
