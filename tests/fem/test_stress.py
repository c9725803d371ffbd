"""Stress recovery against beam theory: a cantilever under a tip load has the bending
moment F (L - x) and, at the surface, the stress M c / I (exact for Hermite beams; P2
tetrahedra within 2 %), and the stress invariants against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from beam_meshes import polyline_mesh

from pipeline.fem import Material, assemble_solid
from pipeline.fem.beam import assemble_beam
from pipeline.fem.section import BeamSection
from pipeline.fem.stress import (
    beam_fibre_stress,
    beam_nodal_resultants,
    principal_stresses,
    solid_nodal_stress,
    tensor_to_voigt,
    voigt_to_tensor,
    von_mises,
)
from pipeline.meshing.mesh_data import MeshData


def _static(model, clamp_nodes, f):
    fixed = model.node_dofs[clamp_nodes].ravel()
    free = np.setdiff1d(np.arange(model.n_dof), fixed)
    u = np.zeros(model.n_dof)
    u[free] = spla.spsolve(model.stiffness[free][:, free].tocsc(), f[free])
    return u


@pytest.mark.parametrize("direction", [(1, 0, 0), (0.3, -0.5, 0.8)])
def test_beam_resultants_of_a_cantilever_are_exact(direction):
    """Tip load P = (30 along the bar, -100 along element y, +50 along element z) N:
    N = 30, Mz = -100 (L - x), My = -50 (L - x), Vy = dMz/ds = 100, Vz = -dMy/ds = -50."""
    L = 2.0
    sec = BeamSection(A=1e-4, Iy=2e-9, Iz=1e-9, J=3e-9, E=2.1e11, G=8e10, rho=7850.0)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    m = assemble_beam(polyline_mesh([[0, 0, 0], L * d], 10), sec, "bar")
    ey, ez = m.extras["frames"][0, 1], m.extras["frames"][0, 2]
    f = np.zeros(m.n_dof)
    f[m.node_dofs[-1, :3]] = 30 * d - 100 * ey + 50 * ez
    r = beam_nodal_resultants(m, _static(m, [0], f)[:, None])[0]
    x = np.linspace(0, L, 11)
    scale = 200.0
    np.testing.assert_allclose(r[:, 0], 30, atol=1e-9 * scale)
    np.testing.assert_allclose(r[:, 1], 100, atol=1e-9 * scale)
    np.testing.assert_allclose(r[:, 2], -50, atol=1e-9 * scale)
    np.testing.assert_allclose(r[:, 3], 0, atol=1e-9 * scale)
    np.testing.assert_allclose(r[:, 4], -50 * (L - x), atol=1e-9 * scale)
    np.testing.assert_allclose(r[:, 5], -100 * (L - x), atol=1e-9 * scale)
    # fibre stress at the top of a 20 mm deep section at mid-span: N/A + M c / I
    c = 0.01
    assert beam_fibre_stress(r[5], sec.A, sec.Iy, sec.Iz, c, 0.0) == pytest.approx(
        30 / sec.A + 100 * (L / 2) * c / sec.Iz, rel=1e-9)


def test_p2_cantilever_bending_stress_is_mc_over_i():
    """Aluminium bar 0.5 x 0.02 x 0.01 m clamped at x = 0, 10 N down at the tip: at
    mid-span the top fibre carries M c / I = 7.5 MPa (tension) and the bottom -7.5 MPa."""
    from skfem import MeshTet

    L, B, H, F = 0.5, 0.02, 0.01, 10.0
    sk = MeshTet.init_tensor(np.linspace(0, L, 21), np.linspace(-B / 2, B / 2, 3),
                             np.linspace(-H / 2, H / 2, 3))
    model = assemble_solid(MeshData(sk.p.T, {"tetra": sk.t.T}, "solid"),
                           Material(E=70e9, nu=0.33, rho=2700.0), "bar")
    P = model.nodes
    tip = np.flatnonzero(np.isclose(P[:, 0], L))
    f = np.zeros(model.n_dof)
    f[model.node_dofs[tip, 2]] = -F / tip.size
    s = solid_nodal_stress(model, _static(model, np.flatnonzero(np.isclose(P[:, 0], 0)),
                                          f)[:, None])[0]
    expected = F * L / 2 * (H / 2) / (B * H ** 3 / 12)
    mid = np.isclose(P[:, 0], L / 2)
    top, bottom = mid & np.isclose(P[:, 2], H / 2), mid & np.isclose(P[:, 2], -H / 2)
    np.testing.assert_allclose(s[top, 0], expected, rtol=0.02)
    np.testing.assert_allclose(s[bottom, 0], -expected, rtol=0.02)
    np.testing.assert_allclose(von_mises(s[top]), expected, rtol=0.03)  # ~uniaxial
    assert np.abs(s[np.isclose(P[:, 2], 0) & mid, 0]).max() < 0.05 * expected  # neutral axis


def test_uniform_strain_stress_is_exact_everywhere():
    """A linear displacement field: every node's stress is Hooke's law of its strain."""
    from skfem import MeshTet

    sk = MeshTet.init_tensor(*[np.linspace(0, 1, 3)] * 3)
    mat = Material(E=200e9, nu=0.3, rho=7800.0)
    model = assemble_solid(MeshData(sk.p.T, {"tetra": sk.t.T}, "solid"), mat, "cube")
    G = np.array([[1.0, 0.2, 0.0], [0.4, -0.5, 0.3], [0.1, 0.0, 0.25]]) * 1e-4  # du_i/dx_j
    u = np.zeros(model.n_dof)
    u[model.node_dofs] = model.nodes @ G.T
    s = solid_nodal_stress(model, u[:, None])[0]
    lam, mu = mat.lame
    eps = 0.5 * (G + G.T)
    sig = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
    voigt = [sig[0, 0], sig[1, 1], sig[2, 2], sig[1, 2], sig[0, 2], sig[0, 1]]
    np.testing.assert_allclose(s, np.tile(voigt, (model.n_nodes, 1)), rtol=1e-9, atol=1e-3)


@pytest.mark.parametrize("chunk", [5, 1024])
def test_several_columns_in_chunks_each_exact(chunk):
    """Three uniform strains at once, the elements taken a few at a time: each column's
    stress is its own Hooke's law (the columns and the chunks are not mixed up)."""
    from skfem import MeshTet

    sk = MeshTet.init_tensor(*[np.linspace(0, 1, 3)] * 3)
    mat = Material(E=200e9, nu=0.3, rho=7800.0)
    model = assemble_solid(MeshData(sk.p.T, {"tetra": sk.t.T}, "solid"), mat, "cube")
    grads = np.random.default_rng(3).standard_normal((3, 3, 3)) * 1e-4
    U = np.zeros((model.n_dof, 3))
    for a, G in enumerate(grads):
        U[model.node_dofs.ravel(), a] = (model.nodes @ G.T).ravel()
    s = solid_nodal_stress(model, U, chunk=chunk)
    lam, mu = mat.lame
    for a, G in enumerate(grads):
        eps = 0.5 * (G + G.T)
        sig = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
        np.testing.assert_allclose(s[a], np.tile(tensor_to_voigt(sig), (model.n_nodes, 1)),
                                   rtol=1e-9, atol=1e-3)


def test_invariants_of_known_states():
    hydro = np.array([5.0, 5.0, 5.0, 0, 0, 0])
    assert von_mises(hydro) == pytest.approx(0.0, abs=1e-12)
    shear = np.array([0.0, 0, 0, 0, 0, 7.0])  # tau_xy: principal +7, 0, -7
    np.testing.assert_allclose(principal_stresses(shear), [7.0, 0.0, -7.0], atol=1e-12)
    rng = np.random.default_rng(0)
    s = rng.standard_normal((50, 6))
    p = principal_stresses(s)
    # von Mises from the principal stresses equals the component form
    vm = np.sqrt(0.5 * ((p[:, 0] - p[:, 1]) ** 2 + (p[:, 1] - p[:, 2]) ** 2
                        + (p[:, 2] - p[:, 0]) ** 2))
    np.testing.assert_allclose(von_mises(s), vm, rtol=1e-12)
    np.testing.assert_allclose(p.sum(axis=1), s[:, :3].sum(axis=1), atol=1e-12)


def test_voigt_and_tensor_forms_agree():
    """Voigt [xx, yy, zz, yz, xz, xy] <-> symmetric tensor, and a uniaxial x stress turned
    90 degrees about z is the uniaxial y stress (the body-axes rotation of the artifact)."""
    s = np.array([1.0, 2, 3, 4, 5, 6])
    T = voigt_to_tensor(s)
    np.testing.assert_array_equal(T, [[1, 6, 5], [6, 2, 4], [5, 4, 3]])
    np.testing.assert_array_equal(tensor_to_voigt(T), s)
    R = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    turned = tensor_to_voigt(R @ voigt_to_tensor([7.0, 0, 0, 0, 0, 0]) @ R.T)
    np.testing.assert_allclose(turned, [0, 7.0, 0, 0, 0, 0], atol=1e-15)
