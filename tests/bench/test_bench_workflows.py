"""Benchmark: every shipped workflow run end to end (full, not --quick), time by stage.

Prints a table and writes output/bench/workflows.json: per workflow the status and
the manifest's seconds per stage (build incl. meshing/reduction, each analysis,
exports, plots, renders, ParaView series). Reduced links are rebuilt once (a cold
cache) and then reused, so both figures are reported.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from pipeline.core.atomic import atomic_open
from pipeline.workflow import build_machine, load_workflow, run_workflow

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "output" / "bench" / "workflows.json"
NAMES = sorted(p.stem for p in (ROOT / "workflows").glob("*.yaml"))


@pytest.mark.bench
def test_bench_workflows(tmp_path):
    """Outputs go to output/<name>/ as with `pipeline run` (the README's pictures come from
    there); the reduced-link cache starts empty (tmp) to time the cold build."""
    figures = {"machine": f"{os.cpu_count()} cores", "workflows": {}}
    for name in NAMES:
        t0 = time.perf_counter()
        res = run_workflow(ROOT / "workflows" / f"{name}.yaml", out_root=ROOT / "output",
                           cache_dir=tmp_path / "links", workers=os.cpu_count() or 1)
        cold = time.perf_counter() - t0
        build_cold = res.manifest["timings_s"]["build"]
        t0 = time.perf_counter()
        build_machine(load_workflow(ROOT / "workflows" / f"{name}.yaml"), tmp_path / "links")
        warm_build = round(time.perf_counter() - t0, 3)
        figures["workflows"][name] = {
            "status": res.manifest["status"], "wall_s_cold_cache": round(cold, 2),
            "build_s_cold": build_cold, "build_s_cached": warm_build,
            "stages_s": res.manifest["timings_s"],
            "analyses": {k: [{"case": c["case"], "seconds": c["seconds"],
                              "outputs": c["outputs"], "success": c["success"]} for c in v]
                         for k, v in res.manifest["analyses"].items()}}
        print(f"\n{name}: {res.manifest['status']}, {cold:.1f} s (cold cache)")
        for k, v in res.manifest["timings_s"].items():
            print(f"  {k:<32} {v:9.2f} s")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(figures, fh, indent=2)
    assert all(w["status"] in ("ok", "partial") for w in figures["workflows"].values())
