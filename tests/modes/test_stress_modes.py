"""Stress modes: a static tip load through a Craig-Bampton basis (the tip's constraint modes
span the static response exactly) gives the full FE static stress; clamped normal modes
alone converge to it as modes are added."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from pipeline.fem import Material, assemble_solid
from pipeline.fem.interfaces import make_interface, tie_interfaces
from pipeline.fem.stress import stress_modes
from pipeline.meshing.mesh_data import MeshData
from pipeline.modes import clamp_reference, clamped_modes

L, B, H, F = 0.4, 0.02, 0.01, 50.0


@pytest.fixture(scope="module")
def tied_bar():
    from skfem import MeshTet

    sk = MeshTet.init_tensor(np.linspace(0, L, 17), np.linspace(-B / 2, B / 2, 3),
                             np.linspace(-H / 2, H / 2, 3))
    model = assemble_solid(MeshData(sk.p.T, {"tetra": sk.t.T}, "solid"),
                           Material(E=210e9, nu=0.3, rho=7850.0), "bar")
    P = model.nodes
    root = make_interface(model, "root", [0, 0, 0], None, "rbe2",
                          np.flatnonzero(np.isclose(P[:, 0], 0)))
    tip = make_interface(model, "tip", [L, 0, 0], None, "rbe2",
                         np.flatnonzero(np.isclose(P[:, 0], L)))
    return model, tie_interfaces(model, [root, tip])


def _tip_load(tied):
    f = np.zeros(tied.n_red)
    f[tied.master_dofs["tip"][2]] = -F  # down along z at the tip's reference point
    return f


def _full_static_stress(model, tied):
    space = clamp_reference(tied, "root")
    x = spla.spsolve(space.project(tied.stiffness).tocsc(), space.L.T @ _tip_load(tied))
    return stress_modes(model, tied.transform @ (space.L @ x))[0]


def _modal_static_stress(model, tied, basis):
    eta = np.linalg.solve(basis.modal_stiffness, basis.reduced_shapes.T @ _tip_load(tied))
    return np.einsum("a,anc->nc", eta, stress_modes(model, basis.shapes))


def test_craig_bampton_static_stress_equals_full_fe(tied_bar):
    model, tied = tied_bar
    full = _full_static_stress(model, tied)
    basis = clamped_modes(tied, "root", n_modes=4, craig_bampton=True)
    modal = _modal_static_stress(model, tied, basis)
    assert np.abs(modal - full).max() < 1e-8 * np.abs(full).max()
    # and the full FE stress is the beam's: mid-span top fibre F (L/2) c / I (3 % on this
    # mesh of 2 x 2 cells across; tests/fem/test_stress.py holds 2 % on a finer one)
    mid_top = np.isclose(model.nodes[:, 0], L / 2) & np.isclose(model.nodes[:, 2], H / 2)
    np.testing.assert_allclose(full[mid_top, 0], F * L / 2 * (H / 2) / (B * H ** 3 / 12),
                               rtol=0.03)


def test_clamped_modes_converge_to_the_static_stress(tied_bar):
    """Normal modes only: the mid-span bending stress converges as bending modes are added
    (the static deflection is 97 % first mode, the stress converges more slowly)."""
    model, tied = tied_bar
    full = _full_static_stress(model, tied)
    mid_top = np.isclose(model.nodes[:, 0], L / 2) & np.isclose(model.nodes[:, 2], H / 2)
    errors = []
    for n in (1, 4, 12):
        modal = _modal_static_stress(model, tied, clamped_modes(tied, "root", n_modes=n))
        errors.append(np.abs(modal[mid_top, 0] - full[mid_top, 0]).max()
                      / np.abs(full[mid_top, 0]).max())
    print("mid-span stress error, 1/4/12 modes:", errors)
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.01
