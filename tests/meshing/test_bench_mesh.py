"""Benchmark (not a timed test): P2 mesh of the aluminium bar 0.4 x 0.008 x 0.004 m.

Target ~55 000 DOF (~18 000 P2 nodes); reference: Netgen meshes it in ~1.9 s on
this machine. Finds the mesh_size that gives the target with the default options,
times gmsh option variants and writes output/bench/mesh_bar.json.
"""

import json
import time
from pathlib import Path

import pytest

from pipeline.core.atomic import atomic_open
from pipeline.meshing import SolidGeometry, build_mesh
from pipeline.meshing.gmsh_build import MESH_OPTIONS

pytestmark = [pytest.mark.bench, pytest.mark.gmsh]

BAR = {"L": 0.4, "b": 0.008, "h": 0.004}
TARGET_NODES = 18_000
VARIANTS = {
    "default (HXT, 1 thread)": {},
    "HXT, 2 threads": {"Mesh.Algorithm3D": 10, "Mesh.MaxNumThreads3D": 2,
                       "General.NumThreads": 2},
    "Delaunay 3D, 1 thread": {"Mesh.Algorithm3D": 1},
    "Delaunay 3D, 2 threads": {"Mesh.Algorithm3D": 1, "Mesh.MaxNumThreads3D": 2,
                               "General.NumThreads": 2},
    "Frontal 3D": {"Mesh.Algorithm3D": 4},
    "HXT, no optimisation": {"Mesh.Optimize": 0},
    "HXT, Delaunay 2D": {"Mesh.Algorithm": 5},
}


def _best_time(size, options, repeats=3):
    best, mesh = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        mesh = build_mesh(SolidGeometry("bar", BAR, size, 2), "bar", options=options)
        best = min(best, time.perf_counter() - t0)
    return best, mesh


def test_bench_bar_p2_mesh():
    build_mesh(SolidGeometry("bar", BAR, 0.004, 2), "warm-up")  # load gmsh once
    sizes = [0.0019, 0.00195, 0.002, 0.00205, 0.0021, 0.00215]
    counts = {h: build_mesh(SolidGeometry("bar", BAR, h, 2), "bar").n_points for h in sizes}
    size = min(sizes, key=lambda h: abs(counts[h] - TARGET_NODES))
    rows = {}
    for label, options in VARIANTS.items():
        seconds, mesh = _best_time(size, options)
        rows[label] = {"seconds": round(seconds, 3), "nodes": mesh.n_points,
                       "dof": 3 * mesh.n_points, "tetra10": len(mesh.cells["tetra10"])}
        print(f"{label:28s} {seconds:6.3f} s  {mesh.n_points} nodes  "
              f"{len(mesh.cells['tetra10'])} tets")
    result = {"geometry": BAR, "order": 2, "mesh_size": size,
              "nodes_by_mesh_size": {str(h): n for h, n in counts.items()},
              "default_options": MESH_OPTIONS, "variants": rows,
              "reference": "Netgen ~1.9 s on this machine"}
    out = Path(__file__).resolve().parents[2] / "output" / "bench" / "mesh_bar.json"
    with atomic_open(out) as fh:
        json.dump(result, fh, indent=2)
    print(f"mesh_size {size} m -> {counts[size]} nodes; written {out}")
    assert rows["default (HXT, 1 thread)"]["nodes"] > 0.9 * TARGET_NODES
