"""Geometric stiffness of beams and the centrifugal load cases, against closed forms:
Euler buckling loads (the geometric stiffness alone), the centrifugal axial force of a
spinning bar rho A w^2 (L^2 - x^2) / 2, and the prestressed string-beam frequencies."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from beam_meshes import polyline_mesh

from pipeline.core.errors import ConfigError
from pipeline.fem.beam import assemble_beam
from pipeline.fem.geometric import (
    beam_axial_forces,
    beam_geometric_stiffness,
    centrifugal_fields,
    centrifugal_loads,
    centrifugal_products,
)
from pipeline.fem.section import BeamSection

L, E, RHO, A, IZ = 2.0, 2.1e11, 7850.0, 1e-4, 1e-9
SEC = BeamSection(A=A, Iy=2 * IZ, Iz=IZ, J=3 * IZ, E=E, G=8e10, rho=RHO)


def _model(direction=(1.0, 0.0, 0.0), n=20):
    d = np.asarray(direction) / np.linalg.norm(direction)
    return assemble_beam(polyline_mesh([[0, 0, 0], L * d], n), SEC, "bar")


def _clamped_solve(model, f):
    free = np.arange(6, model.n_dof)  # node 0 clamped
    u = np.zeros(model.n_dof)
    K = model.stiffness.toarray()
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    return u


def test_cantilever_buckling_load_is_euler():
    """K u = lambda (-K_G(N = -1 N)) u: the lowest lambda is the critical compression
    pi^2 E Iz / (4 L^2) (weak axis), the next one 4x that of the other plane (Iy = 2 Iz)."""
    m = _model()
    free = np.arange(6, m.n_dof)
    K = m.stiffness.toarray()[np.ix_(free, free)]
    KG = beam_geometric_stiffness(m, -np.ones(20)).toarray()[np.ix_(free, free)]
    lam = np.sort(sla.eigvals(K, -KG).real)
    lam = lam[np.isfinite(lam) & (lam > 0)]
    p_cr = np.pi ** 2 * E * IZ / (4 * L ** 2)
    assert lam[0] == pytest.approx(p_cr, rel=1e-5)
    assert lam[1] == pytest.approx(2 * p_cr, rel=1e-5)  # the x-z plane, Iy = 2 Iz


def test_tension_raises_string_beam_frequency():
    """Pinned-pinned (simply supported) beam under tension N: the first lateral frequency
    follows omega^2 = omega_0^2 (1 + N / N_cr), N_cr = pi^2 EI / L^2 (same half-sine)."""
    m = _model()
    n_cr = np.pi ** 2 * E * IZ / L ** 2
    dofs = m.node_dofs
    fixed = np.r_[dofs[0, :4], dofs[-1, 1:4]]  # pins: translations and torsion
    free = np.setdiff1d(np.arange(m.n_dof), fixed)
    K0, M = (x.toarray()[np.ix_(free, free)] for x in (m.stiffness, m.mass))
    w0 = None
    for ratio in (0.0, 0.25, 0.5, -0.25, -0.5):
        KG = beam_geometric_stiffness(m, np.full(20, ratio * n_cr)).toarray()[np.ix_(free, free)]
        lam = sla.eigh(K0 + KG, M, eigvals_only=True, subset_by_index=[0, 0])[0]
        w0 = lam if ratio == 0 else w0
        assert lam == pytest.approx(w0 * (1 + ratio), rel=1e-4)


@pytest.mark.parametrize("direction", [(1, 0, 0), (0.3, -0.5, 0.8)])
def test_centrifugal_axial_force_of_a_spinning_bar(direction):
    """A bar spinning about an axis through its root, perpendicular to it: the static
    axial force is rho A w^2 (L^2 - x^2) / 2 (each element carries the mean over its
    length); the resultant load is rho A w^2 L^2 / 2 along the bar."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    m = _model(d)
    axis = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    w = 3.0 * axis / np.linalg.norm(axis)
    f = np.einsum("c,cn->n", centrifugal_products(w), centrifugal_loads(m, [0, 0, 0]))
    resultant = f[m.node_dofs[:, :3]].sum(axis=0)
    np.testing.assert_allclose(resultant, RHO * A * 9.0 * L ** 2 / 2 * d, rtol=1e-12,
                               atol=1e-12)
    N = beam_axial_forces(m, _clamped_solve(m, f))
    s = np.linspace(0, L, 21)
    a, b = s[:-1], s[1:]
    mean = RHO * A * 9.0 / 2 * (L ** 2 - (a ** 2 + a * b + b ** 2) / 3)
    np.testing.assert_allclose(N, mean, rtol=1e-9)


def test_oblique_spin_bends_the_bar_as_a_triangular_load():
    """Bar along x spinning with w = (wx, wy, 0): the transverse part of the field is
    -rho A wx wy x along y, a triangular load whose cantilever tip deflection is
    11 q_L L^4 / (120 E Iz) (exact for Hermite elements with consistent loads)."""
    m = _model()
    wx, wy = 1.5, -2.0
    f = np.einsum("c,cn->n", centrifugal_products([wx, wy, 0.0]), centrifugal_loads(m, [0, 0, 0]))
    u = _clamped_solve(m, f)
    q_tip = -RHO * A * wx * wy * L
    assert u[m.node_dofs[-1, 1]] == pytest.approx(11 * q_tip * L ** 4 / (120 * E * IZ),
                                                  rel=1e-10)


def test_loads_follow_the_body_axes_and_origin():
    """Cases given in rotated body axes about a shifted origin equal the ground cases of
    the rotated angular velocity about that origin."""
    m = _model((1.0, 0.2, -0.1))
    Rb = sla.expm(np.array([[0, -0.4, 0.2], [0.4, 0, -0.7], [-0.2, 0.7, 0]]))
    o = np.array([0.3, -0.2, 0.1])
    w_body = np.array([0.5, -1.2, 2.0])
    body = np.einsum("c,cn->n", centrifugal_products(w_body), centrifugal_loads(m, o, Rb))
    ground = np.einsum("c,cn->n", centrifugal_products(Rb @ w_body), centrifugal_loads(m, o))
    np.testing.assert_allclose(body, ground, atol=1e-12 * np.abs(ground).max())
    B = np.einsum("c,cij->ij", centrifugal_products(w_body), centrifugal_fields(Rb))
    wg = Rb @ w_body
    np.testing.assert_allclose(B, wg @ wg * np.eye(3) - np.outer(wg, wg), atol=1e-14)


def test_solids_are_refused_with_a_reason():
    from dataclasses import replace

    with pytest.raises(ConfigError, match="beam links only"):
        centrifugal_loads(replace(_model(), kind="solid"), [0, 0, 0])


def test_centrifugal_tensor_gives_the_same_stiffness_for_any_spin():
    """w^T G w from the 3 x 3 form equals sum_c p_c(w) K_c of the six stored cases."""
    from pipeline.fem.geometric import centrifugal_tensor

    rng = np.random.default_rng(4)
    K = rng.standard_normal((6, 3, 3))
    G = centrifugal_tensor(K)
    for _ in range(5):
        w = rng.standard_normal(3)
        np.testing.assert_allclose(np.einsum("i,j,ijab->ab", w, w, G),
                                   np.einsum("c,cab->ab", centrifugal_products(w), K),
                                   rtol=1e-12, atol=1e-12)


def test_acceleration_loads_carry_the_mass_and_its_moment():
    """A unit acceleration along each axis: the loads add up to the link's mass along that
    axis, point masses included, with the moment of the mass about the origin; on the
    clamped bar along x they make the axial force rho A (L - x) (N per m/s^2)."""
    from pipeline.fem.geometric import acceleration_loads
    from pipeline.fem.point_masses import PointMass, add_point_masses

    d = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    bare = _model(d)
    tip = 0.3
    model = add_point_masses(bare, [PointMass("lump", L * d, tip)], "bar")
    mass = RHO * A * L + tip
    xc = (RHO * A * L * L / 2 + tip * L) / mass * d
    f = acceleration_loads(model)
    for k in range(3):
        forces = f[k][model.node_dofs[:, :3]]
        moments = f[k][model.node_dofs[:, 3:]]
        np.testing.assert_allclose(forces.sum(axis=0), mass * np.eye(3)[k], atol=1e-12 * mass)
        moment = np.cross(model.nodes, forces).sum(axis=0) + moments.sum(axis=0)
        np.testing.assert_allclose(moment, np.cross(mass * xc, np.eye(3)[k]), atol=1e-12 * mass)
    axial = acceleration_loads(_model(), np.eye(3))[0]
    x = _model().nodes[:, 0]
    N = beam_axial_forces(_model(), _clamped_solve(_model(), axial))
    mid = 0.5 * (x[:-1] + x[1:])
    np.testing.assert_allclose(N, RHO * A * (L - mid), rtol=1e-9)


def test_inertia_cases_combine_into_the_centrifugal_ones():
    """The twelve unit inertia fields rho xb_j e_k span every inertia load: the centrifugal
    cases are sum_jk B_c[k, j] of the linear ones, exactly, for beams (about a point off
    the bar, in rotated body axes) and P2 solids."""
    from skfem import MeshTet

    from pipeline.fem import Material, assemble_solid
    from pipeline.fem.geometric import inertia_loads, solid_centrifugal_loads
    from pipeline.kinematics.rotations import rot_x, rot_z
    from pipeline.meshing.mesh_data import MeshData

    o, Rb = np.array([0.3, -0.2, 0.1]), rot_z(0.4) @ rot_x(-0.7)
    beam = _model((1.0, 2.0, 0.5))
    sk = MeshTet.init_tensor(np.linspace(0, 0.5, 6), np.linspace(0, 0.02, 2),
                             np.linspace(0, 0.01, 2))
    solid = assemble_solid(MeshData(sk.p.T, {"tetra": sk.t.T}, "solid"),
                           Material(E=E, nu=0.3, rho=RHO), "bar")
    for model, direct in ((beam, centrifugal_loads), (solid, solid_centrifugal_loads)):
        ref = direct(model, o, Rb)
        combined = np.einsum("ckj,jkn->cn", centrifugal_fields(), inertia_loads(model, o, Rb)[:3])
        np.testing.assert_allclose(combined, ref, atol=1e-12 * np.abs(ref).max())
