"""Benchmark (not a timed test): P2 elasticity + mass assembly of the aluminium bar
0.4 x 0.008 x 0.004 m.

* ~55 000 DOF: :func:`assemble_solid` (whole stage: topology, kernel, DOF
  numbering, scalar mass, boundary) and the kernel alone vs scikit-fem's plain
  ``asm`` of K and M (basis construction included). Reference on this machine:
  skfem's ``asm`` of K ~9 s, NGsolve K and M ~0.9 s.
* ~500 000 DOF: :func:`assemble_solid` only (time and peak memory).

Peak memory is the tracemalloc peak of the traced call (numpy and scipy buffers)
measured in a separate run from the timing. Writes output/bench/assembly.json.
"""

from __future__ import annotations

import importlib.util
import json
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from pipeline.core.atomic import atomic_open
from pipeline.fem import Material, assemble_solid, p2_topology
from pipeline.fem.p2_kernel import assemble_p2
from pipeline.meshing.mesh_data import MeshData

pytestmark = pytest.mark.bench

BAR = {"L": 0.4, "b": 0.008, "h": 0.004}
ALUMINIUM = Material(E=70e9, nu=0.33, rho=2700.0)
HAVE_GMSH = importlib.util.find_spec("gmsh") is not None


def bar_mesh(size: float, divisions: tuple[int, int, int]) -> MeshData:
    """gmsh P2 (tetra10) mesh of the bar if gmsh is there, else skfem's structured tetra."""
    if HAVE_GMSH:
        from pipeline.meshing import SolidGeometry, build_mesh

        return build_mesh(SolidGeometry("bar", BAR, size, 2), "bar")
    from skfem import MeshTet

    L, b, h = BAR["L"], BAR["b"], BAR["h"]
    nx, ny, nz = divisions
    m = MeshTet.init_tensor(np.linspace(0, L, nx + 1), np.linspace(-b / 2, b / 2, ny + 1),
                            np.linspace(-h / 2, h / 2, nz + 1))
    return MeshData(m.p.T, {"tetra": m.t.T}, "solid")


def best_of(fn, repeats: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def traced_peak_mib(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def skfem_asm(mesh: MeshData):
    """K and M with skfem's Basis + asm (linear_elasticity, vector mass)."""
    from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity

    rho = ALUMINIUM.rho

    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)

    topo = p2_topology(mesh, "bar")
    t0 = time.perf_counter()
    basis = Basis(topo.mesh, ElementVector(ElementTetP2()))
    t_basis = time.perf_counter() - t0
    t0 = time.perf_counter()
    K = asm(linear_elasticity(*ALUMINIUM.lame), basis)
    t_K = time.perf_counter() - t0
    t0 = time.perf_counter()
    M = asm(mass, basis)
    t_M = time.perf_counter() - t0
    return {"basis_s": t_basis, "K_s": t_K, "M_s": t_M}, K, M


def kernel_only(mesh: MeshData):
    topo = p2_topology(mesh, "bar")
    X = topo.coords[topo.conn]
    lam, mu = ALUMINIUM.lame
    return lambda: assemble_p2(X, topo.conn, topo.coords.shape[0], lam, mu, topo.straight)


def case(mesh: MeshData, repeats: int) -> dict:
    assemble_solid(mesh, ALUMINIUM, "bar")  # warm-up (imports, caches)
    t_total, model = best_of(lambda: assemble_solid(mesh, ALUMINIUM, "bar"), repeats)
    t_kernel, _ = best_of(kernel_only(mesh), repeats)
    peak = traced_peak_mib(lambda: assemble_solid(mesh, ALUMINIUM, "bar"))
    row = {"nodes": model.n_nodes, "dof": model.n_dof, "cells": len(model.extras["cells"]),
           "K_nnz": int(model.stiffness.nnz), "assemble_solid_s": round(t_total, 3),
           "kernel_K_and_M_s": round(t_kernel, 3), "peak_traced_MiB": round(peak, 1)}
    print(f"{model.n_dof:8d} DOF: assemble_solid {t_total:.3f} s (kernel K+M {t_kernel:.3f} s), "
          f"peak {peak:.0f} MiB, K nnz {model.stiffness.nnz}")
    return row, model


def test_bench_p2_assembly():
    mesh = bar_mesh(0.002, (100, 8, 4))
    row, model = case(mesh, repeats=3)
    times, K0, M0 = skfem_asm(mesh)
    diff_K = float(abs(model.stiffness - K0).max() / abs(K0).max())
    diff_M = float(abs(model.mass - M0).max() / abs(M0).max())
    skfem_total = sum(times.values())
    print(f"skfem asm: basis {times['basis_s']:.2f} s, K {times['K_s']:.2f} s, "
          f"M {times['M_s']:.2f} s; relative differences K {diff_K:.1e}, M {diff_M:.1e}; "
          f"speed-up {skfem_total / row['assemble_solid_s']:.1f}x")
    big_mesh = bar_mesh(0.00086, (230, 18, 10))
    big, _ = case(big_mesh, repeats=1)
    result = {
        "geometry": BAR, "material": {"E": ALUMINIUM.E, "nu": ALUMINIUM.nu, "rho": ALUMINIUM.rho},
        "mesher": "gmsh tetra10" if HAVE_GMSH else "skfem structured tetra",
        "bar_55k": {**row, "skfem_asm": {k: round(v, 3) for k, v in times.items()},
                    "skfem_asm_total_s": round(skfem_total, 3),
                    "relative_difference_vs_skfem": {"K": diff_K, "M": diff_M}},
        "bar_500k": big,
        "max_rss_MiB": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "reference": "skfem asm of K ~9 s, NGsolve K and M ~0.9 s on this machine",
    }
    out = Path(__file__).resolve().parents[2] / "output" / "bench" / "assembly.json"
    with atomic_open(out) as fh:
        json.dump(result, fh, indent=2)
    print(f"written {out}")
    assert diff_K < 1e-12 and diff_M < 1e-12
