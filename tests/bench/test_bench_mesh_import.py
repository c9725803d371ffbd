"""Benchmark (issue 28): a boom brought as an FE mesh file against the same boom meshed
here. The excavator's box-section boom (meshes/excavator_boom.yaml, 16 Craig-Bampton
modes) at about 500 k P2 DOF:

1. meshed by gmsh from its recipe and reduced; its FE mesh written as Abaqus ``.inp``
   (``pipeline reduce --mesh``), with the bores' node sets;
2. the ``.inp`` imported (``geometry: {type: mesh}``, the same interfaces by the same set
   names) and reduced;
3. the imported link asked for again: a link-cache hit.

Each in a fresh subprocess (its own peak memory), one after the other. Prints and writes
``output/bench/mesh_import.json``: seconds per stage, peak memory, the cache hit's time,
and how far the imported link's frequencies are from the meshed one's. Not a timed test.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

from pipeline.core.atomic import atomic_open

pytestmark = [pytest.mark.bench, pytest.mark.gmsh]

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "output" / "bench" / "mesh_import.json"
#: the boom's mesh size (m) for about 500 k P2 DOF (0.03 gives 191 k, 0.0215 366 k)
MESH_SIZE = 0.018

CASE = textwrap.dedent("""
    import json, resource, sys, time
    from pathlib import Path
    from pipeline.workflow.link_build import reduce_cached
    from pipeline.workflow.link_spec import load_link_spec
    spec_path, cache, mesh_out = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
    t0 = time.perf_counter()
    spec = load_link_spec(spec_path)
    link, status, _ = reduce_cached(spec, spec_path.parent, cache)
    total = time.perf_counter() - t0
    out = {"dof": link.meta["n_dof"], "status": status, "total_s": total,
           "stages_s": dict(link.meta["stage_seconds"]) if status != "hit" else {},
           "frequencies_hz": [float(f) for f in link.frequencies_hz]}
    if mesh_out:
        from pipeline.invariants.mesh_export import write_link_mesh
        t0 = time.perf_counter()
        write_link_mesh(link, Path(mesh_out))
        out["write_mesh_s"] = time.perf_counter() - t0
        out["mesh_mib"] = Path(mesh_out).stat().st_size / 2**20
    out["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(out))
""")


def _run(spec: Path, cache: Path, mesh_out: str = "") -> dict:
    out = subprocess.run([sys.executable, "-c", CASE, str(spec), str(cache), mesh_out],
                         capture_output=True, text=True, timeout=3600, cwd=ROOT, check=False)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_bench_imported_boom_against_meshing_it(tmp_path):
    base = yaml.safe_load((ROOT / "meshes" / "excavator_boom.yaml").read_text())
    meshed = dict(base, geometry={**base["geometry"], "mesh_size": MESH_SIZE})
    # the same spec but its geometry: the .inp names the bores' nodes as the gmsh groups
    # the interfaces select (bore_foot, ...)
    imported = dict(base, name="excavator_boom_inp",
                    geometry={"type": "mesh", "path": "boom.inp", "units": "m"})
    for name, spec in (("meshed", meshed), ("imported", imported)):
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    cache = tmp_path / "links"
    runs = {"meshed": _run(tmp_path / "meshed.yaml", cache, str(tmp_path / "boom.inp"))}
    runs["imported"] = _run(tmp_path / "imported.yaml", cache)
    runs["cache_hit"] = _run(tmp_path / "imported.yaml", cache)
    assert runs["imported"]["status"] == "miss" and runs["cache_hit"]["status"] == "hit"
    f0, f1 = (runs[k]["frequencies_hz"] for k in ("meshed", "imported"))
    gap = max(abs(a / b - 1.0) for a, b in zip(f1, f0, strict=True))
    result = {"machine": f"{os.cpu_count()}-core shared machine, 24 GB",
              "case": f"meshes/excavator_boom.yaml at mesh_size {MESH_SIZE} m, "
                      f"{runs['meshed']['dof']} P2 DOF, 16 Craig-Bampton modes",
              "runs": runs, "frequency_gap_imported_vs_meshed": gap}
    for name, r in runs.items():
        print(f"\n{name}: {r['total_s']:.1f} s, peak {r['peak_rss_mib'] / 1024:.2f} GiB")
        for stage, s in r["stages_s"].items():
            print(f"   {stage:55s} {s:8.2f} s")
    print(f"\nlargest frequency gap, imported vs meshed: {gap:.2e}")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT, "w") as fh:
        json.dump(result, fh, indent=1)
    assert gap < 1e-8
