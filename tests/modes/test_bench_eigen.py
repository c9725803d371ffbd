"""Benchmark (not a timed test): clamped modes of the aluminium bar 0.4 x 0.008 x 0.004 m
in P2 tetrahedra (~55 800 DOF, gmsh mesh_size 2.05 mm), clamped by an RBE2 at x = 0.

Measures, for the factorisation of the clamped K (shift 0) with SuperLU:
fill-reducing ordering x symmetric mode -> factorisation time, fill (nnz of L + U)
and the time of 20 shift-invert Lanczos modes; then the whole ``clamped_modes``
(20 modes) and a Craig-Bampton basis (tip RBE2, 20 fixed-interface modes).
Prints and writes output/bench/modes_eigen.json.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pipeline.core.atomic import atomic_open
from pipeline.fem.interfaces import InterfaceSpec, resolve_interfaces, tie_interfaces
from pipeline.modes import clamped_modes
from pipeline.modes.clamp import clamp_reference

pytestmark = [pytest.mark.bench, pytest.mark.gmsh]

BAR = {"L": 0.4, "b": 0.008, "h": 0.004}
N_MODES = 20


def _model():
    from pipeline.fem.material import Material
    from pipeline.fem.solid import assemble_solid
    from pipeline.meshing.geometry import SolidGeometry
    from pipeline.meshing.gmsh_build import build_mesh
    from pipeline.meshing.selectors import PhysicalGroup

    mesh = build_mesh(SolidGeometry("bar", BAR, mesh_size=0.00205), "bar")
    model = assemble_solid(mesh, Material(E=70e9, nu=0.33, rho=2700.0), "bar")
    specs = [InterfaceSpec("root", PhysicalGroup("end_x0"), [0, 0, 0]),
             InterfaceSpec("tip", PhysicalGroup("end_xL"), [BAR["L"], 0, 0])]
    return model, resolve_interfaces(model, specs, mesh.groups)


def _variant(K, M, ordering, symmetric):
    kwargs = {"options": {"SymmetricMode": True}, "diag_pivot_thresh": 0.0} if symmetric else {}
    t0 = time.perf_counter()
    lu = spla.splu(sp.csc_matrix(K), permc_spec=ordering, **kwargs)
    t_fact = time.perf_counter() - t0
    op = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(K.shape[0])
    t0 = time.perf_counter()
    lam = spla.eigsh(K, k=N_MODES, M=M, sigma=0.0, OPinv=op, v0=v0, tol=0.0,
                     return_eigenvectors=False)
    t_eig = time.perf_counter() - t0
    return {"factor_s": round(t_fact, 3), "fill_nnz_LU": int(lu.L.nnz + lu.U.nnz),
            "eigsh_20_s": round(t_eig, 3), "total_s": round(t_fact + t_eig, 3),
            "f1_hz": float(np.sqrt(np.min(lam)) / (2 * np.pi))}


def test_bench_clamped_modes_55k():
    model, (root, tip) = _model()
    t0 = time.perf_counter()
    tied = tie_interfaces(model, [root, tip])
    t_tie = time.perf_counter() - t0
    space = clamp_reference(tied, "root")
    K, M = space.project(tied.stiffness), space.project(tied.mass)
    variants = {}
    for ordering, symmetric in (("MMD_AT_PLUS_A", True), ("MMD_AT_PLUS_A", False),
                                ("COLAMD", False), ("COLAMD", True), ("MMD_ATA", True)):
        key = f"{ordering}{' +SymmetricMode' if symmetric else ''}"
        variants[key] = _variant(K, M, ordering, symmetric)
        print(f"{key:30s} {variants[key]}")
    t0 = time.perf_counter()
    basis = clamped_modes(tied, "root", n_modes=N_MODES)
    t_modes = time.perf_counter() - t0
    t0 = time.perf_counter()
    cb = clamped_modes(tied, "root", n_modes=N_MODES, craig_bampton=True)
    t_cb = time.perf_counter() - t0
    E, rho, h, L = 70e9, 2700.0, BAR["h"], BAR["L"]
    f_eb = 1.8751040687 ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E * h ** 2 / 12 / rho)
    result = {
        "model": {"dof": model.n_dof, "tied_dof": tied.n_red, "clamped_dof": space.n_c,
                  "K_nnz": int(K.nnz)},
        "tie_interfaces_s": round(t_tie, 3), "orderings": variants,
        "clamped_modes_20_s": round(t_modes, 3), "craig_bampton_20_plus_6_s": round(t_cb, 3),
        "f1_hz": float(basis.frequencies_hz[0]), "f1_euler_bernoulli_hz": f_eb,
        "f1_relative_error": float(basis.frequencies_hz[0] / f_eb - 1),
        "cb_f1_hz": float(cb.frequencies_hz[0]),
    }
    print(json.dumps({k: v for k, v in result.items() if k != "orderings"}, indent=1))
    out = Path(__file__).resolve().parents[2] / "output" / "bench" / "modes_eigen.json"
    with atomic_open(out) as fh:
        json.dump(result, fh, indent=2)
