"""Beam natural frequencies vs closed forms (Euler-Bernoulli, quarter-wave rods).

Slender cantilever: L = 2 m, radii of gyration r_z = sqrt(Iz/A) = 1 mm and
r_y = 2 mm, so L/r >= 1000. The Rayleigh rotary-inertia shift of mode n is
about -(beta_n r)^2 / 2: at most -(10.996 * 2e-3 / 2)^2 / 2 = -6e-5 for the
modes compared here, far below the 0.1 % tolerance; the Hermite discretisation
error with 40 elements is ~(beta h)^4, below 1e-6.
"""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from beam_meshes import polyline_mesh

from pipeline.fem.beam import assemble_beam
from pipeline.fem.section import BeamSection

L, N_EL = 2.0, 40
SEC = dict(A=1e-4, Iy=4e-10, Iz=1e-10, J=3e-10, E=2.1e11, G=8.1e10, rho=7850.0)
BETA_L = np.array([1.875104069, 4.694091133, 7.854757438, 10.99554073])


def frame_of(e, y_axis):
    hint = np.cross([0.0, 0.0, 1.0], e) if y_axis is None else np.asarray(y_axis, float)
    ey = hint - hint @ e * e
    ey /= np.linalg.norm(ey)
    return np.array([e, ey, np.cross(e, ey)])


def eb_cantilever(I, n=3):
    """Euler-Bernoulli cantilever circular frequencies, rad/s."""
    return BETA_L[:n] ** 2 / L**2 * np.sqrt(SEC["E"] * I / (SEC["rho"] * SEC["A"]))


def clamped_cantilever(direction, y_axis):
    e = np.asarray(direction, float) / np.linalg.norm(direction)
    p0 = np.array([0.3, -0.2, 0.5])
    model = assemble_beam(polyline_mesh([p0, p0 + L * e], N_EL),
                          BeamSection(**SEC, y_axis=y_axis), "cantilever")
    free = model.node_dofs[1:].ravel()  # clamp node 0
    return model, free, e


def local_subproblems(model, free, R):
    """K, M in element-local DOFs split into axial, torsion, x-y and x-z planes.

    Asserts the four groups are uncoupled (they are for a straight beam only if
    the frame rotation is right).
    """
    T = sp.kron(sp.identity(model.n_nodes), sp.block_diag([R, R])).tocsr()
    K = (T @ model.stiffness @ T.T).toarray()[np.ix_(free, free)]
    M = (T @ model.mass @ T.T).toarray()[np.ix_(free, free)]
    comp = np.arange(len(free)) % 6
    groups = {"axial": [0], "torsion": [3], "xy": [1, 5], "xz": [2, 4]}
    idx = {k: np.flatnonzero(np.isin(comp, v)) for k, v in groups.items()}
    for a in idx:
        for b in idx:
            if a != b:
                assert np.abs(K[np.ix_(idx[a], idx[b])]).max() < 1e-12 * np.abs(K).max()
                assert np.abs(M[np.ix_(idx[a], idx[b])]).max() < 1e-12 * np.abs(M).max()
    return {k: np.sqrt(sla.eigh(K[np.ix_(i, i)], M[np.ix_(i, i)], eigvals_only=True))
            for k, i in idx.items()}


CASES = [((1.0, 0.0, 0.0), None), ((1.0, 2.0, 2.0), None), ((1.0, 2.0, 2.0), (0.5, -1.0, 0.3)),
         ((-0.2, 0.1, 1.0), None)]


@pytest.mark.parametrize("direction, y_axis", CASES)
def test_cantilever_bending_axial_torsion_frequencies(direction, y_axis):
    model, free, e = clamped_cantilever(direction, y_axis)
    omega = local_subproblems(model, free, frame_of(e, y_axis))
    # bending in the local x-y plane uses Iz, in the x-z plane Iy
    for plane, I in (("xy", SEC["Iz"]), ("xz", SEC["Iy"])):
        rel = omega[plane][:3] / eb_cantilever(I) - 1
        assert np.all(np.abs(rel) < 1e-3), (plane, rel)
        assert np.all(rel < 0)  # the rotary-inertia (Rayleigh) shift lowers them
    n = np.arange(1, 3)
    axial = (2 * n - 1) * np.pi / (2 * L) * np.sqrt(SEC["E"] / SEC["rho"])
    torsion = (2 * n - 1) * np.pi / (2 * L) * np.sqrt(
        SEC["G"] * SEC["J"] / (SEC["rho"] * (SEC["Iy"] + SEC["Iz"])))
    np.testing.assert_allclose(omega["axial"][:2], axial, rtol=1e-3)
    np.testing.assert_allclose(omega["torsion"][:2], torsion, rtol=1e-3)
    # Sharper: linear elements with consistent mass on a uniform mesh have the
    # exact discrete modes sin(k x), k L = (2n - 1) pi / 2 (the free end is a
    # mirror plane), with omega_h = c sqrt(6 (1 - cos kh) / (h^2 (2 + cos kh))).
    kh = (2 * n - 1) * np.pi / (2 * L) * (L / N_EL)
    dispersion = np.sqrt(6 * (1 - np.cos(kh)) / (2 + np.cos(kh))) / kh
    np.testing.assert_allclose(omega["axial"][:2], axial * dispersion, rtol=1e-10)
    np.testing.assert_allclose(omega["torsion"][:2], torsion * dispersion, rtol=1e-10)


def test_full_model_eigsh_lowest_modes_and_orientation_invariance():
    """Shift-invert on the whole clamped 3D model: the lowest six frequencies are
    the merged Euler-Bernoulli spectra of both planes, and an oblique beam has
    the same spectrum as the axis-aligned one."""
    expected = np.sort(np.concatenate([eb_cantilever(SEC["Iz"], 4), eb_cantilever(SEC["Iy"], 4)]))
    spectra = []
    for direction, y_axis in CASES:
        model, free, _ = clamped_cantilever(direction, y_axis)
        K = model.stiffness[free][:, free]
        M = model.mass[free][:, free]
        lam = spla.eigsh(K, k=6, M=M, sigma=0.0, which="LM", return_eigenvectors=False)
        spectra.append(np.sqrt(np.sort(lam)))
        np.testing.assert_allclose(spectra[-1], expected[:6], rtol=1e-3)
    # shift-invert on K (condition ~1e13, axial vs bending) resolves these to ~1e-8
    np.testing.assert_allclose(spectra[1:], np.broadcast_to(spectra[0], (3, 6)), rtol=1e-7)


def test_crane_boom_polyline_has_six_rigid_modes():
    """Three kinked members with different sections (steel, A and I of a
    telescopic boom): free-free, exactly six zero frequencies; K annihilates the
    rigid motions u = t + w x x, theta = w built here."""
    vertices = [[0, 0, 0], [4.0, 0.0, 6.93], [8.1, 0.2, 13.8], [12.0, 0.2, 20.8]]
    mesh = polyline_mesh(vertices, 8)
    secs = [BeamSection(A=a, Iy=iy, Iz=iz, J=iy + iz, E=2.1e11, G=8.1e10, rho=7850.0)
            for a, iy, iz in ((0.0183, 6.0e-4, 4.0e-4), (0.0152, 4.5e-4, 3.0e-4),
                              (0.0120, 3.0e-4, 2.0e-4))]
    per_element = [secs[min(e // 8, 2)] for e in range(24)]
    model = assemble_beam(mesh, per_element, "boom")
    lam = spla.eigsh(model.stiffness, k=10, M=model.mass, sigma=-1.0, which="LM",
                     return_eigenvectors=False)
    lam = np.sort(lam)
    assert np.all(np.abs(lam[:6]) < 1e-8 * lam[6]), lam
    assert lam[6] > 1.0  # first elastic mode well above zero (rad^2/s^2)
    rigid = np.zeros((model.n_dof, 6))
    for j in range(3):
        rigid[model.node_dofs[:, j], j] = 1.0
        w = np.eye(3)[j]
        rigid[model.node_dofs[:, :3], 3 + j] = np.cross(w, model.nodes)
        rigid[model.node_dofs[:, 3 + j], 3 + j] = 1.0
    residual = np.abs(model.stiffness @ rigid).max()
    assert residual < 1e-12 * abs(model.stiffness).max() * np.abs(rigid).max()
    # the rigid motions carry the total mass: sum of rho A L of the members
    lengths = np.linalg.norm(np.diff(np.asarray(vertices, float), axis=0), axis=1)
    m_total = sum(s.rho * s.A * Lm for s, Lm in zip(secs, lengths))
    for j in range(3):
        assert rigid[:, j] @ model.mass @ rigid[:, j] == pytest.approx(m_total, rel=1e-13)
