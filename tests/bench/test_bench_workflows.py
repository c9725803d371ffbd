"""Benchmark: every shipped workflow run end to end (full, not --quick), time by stage.

Prints a table and writes output/bench/workflows.json: per workflow, run twice --
cold (an empty reduced-link cache: meshing, assembly, eigen solve; the compiled
dynamics kernels stay in numba's on-disk cache) and warm (the links read back) --
the status, the wall time, the manifest's seconds per stage (build, each analysis,
exports, plots, renders, ParaView series) and the size of the output folder. Goals
(issue 13): the main job <= 30 s warm, every shipped workflow <= 60 s warm, <= 50 MB.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from pipeline.core.atomic import atomic_open
from pipeline.workflow import run_workflow

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "output" / "bench" / "workflows.json"
NAMES = sorted(p.stem for p in (ROOT / "workflows").glob("*.yaml"))


def _size_mb(folder: Path) -> float:
    return round(sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) / 1e6, 1)


def _run(name, out_root, cache):
    t0 = time.perf_counter()
    res = run_workflow(ROOT / "workflows" / f"{name}.yaml", out_root=out_root,
                       cache_dir=cache, workers=os.cpu_count() or 1)
    return {"status": res.manifest["status"], "wall_s": round(time.perf_counter() - t0, 2),
            "stages_s": res.manifest["timings_s"], "output_mb": _size_mb(out_root / name),
            "analyses": {k: [{"case": c["case"], "seconds": c["seconds"],
                              "outputs": c["outputs"], "success": c["success"]} for c in v]
                         for k, v in res.manifest["analyses"].items()}}


@pytest.mark.bench
def test_bench_workflows(tmp_path):
    """The warm run's outputs go to output/<name>/ as with `pipeline run` (the README's
    pictures come from there); the cold one writes to tmp."""
    figures = {"machine": f"{os.cpu_count()} cores", "workflows": {}}
    for name in NAMES:
        cache = tmp_path / "links"
        cold = _run(name, tmp_path / "cold", cache)
        warm = _run(name, ROOT / "output", cache)
        figures["workflows"][name] = {"cold": cold, "warm": warm}
        print(f"\n{name}: {warm['status']}, cold {cold['wall_s']:.1f} s, warm "
              f"{warm['wall_s']:.1f} s, {warm['output_mb']} MB")
        for k in warm["stages_s"]:
            print(f"  {k:<40} {cold['stages_s'].get(k, float('nan')):9.2f} "
                  f"{warm['stages_s'][k]:9.2f} s")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(figures, fh, indent=2)
    assert all(w[k]["status"] in ("ok", "partial") for w in figures["workflows"].values()
               for k in ("cold", "warm"))
