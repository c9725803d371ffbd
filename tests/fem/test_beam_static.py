"""Static beam deflections vs closed forms (exact at the nodes for Hermite/P1).

Hermite cubics contain the exact Euler-Bernoulli solution under end loads and
linear elements the exact axial/torsion solution, so nodal values must agree
with the formulas to rounding, in any orientation of the member.
"""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from beam_meshes import polyline_mesh
from scipy.spatial.transform import Rotation

from pipeline.fem.beam import assemble_beam
from pipeline.fem.section import BeamSection

E, G = 2.1e11, 8.1e10


def solve_clamped(model, clamped_node, loads):
    """Static solution with one node clamped; loads: {node: (6,) force/moment}."""
    f = np.zeros(model.n_dof)
    for node, fm in loads.items():
        f[model.node_dofs[node]] += fm
    free = np.setdiff1d(np.arange(model.n_dof), model.node_dofs[clamped_node])
    u = np.zeros(model.n_dof)
    u[free] = spla.spsolve(model.stiffness[free][:, free].tocsc(), f[free])
    return u[model.node_dofs]  # (n_nodes, 6)


@pytest.fixture(scope="module")
def oblique_cantilever():
    L, n_el = 1.7, 10
    Q = Rotation.from_rotvec([0.4, -0.9, 0.3]).as_matrix()
    ex, ey, ez = Q.T  # member frame in the link frame
    p0 = np.array([0.2, 0.1, -0.4])
    sec = BeamSection(A=2e-4, Iy=3e-8, Iz=1.2e-8, J=2.5e-8, E=E, G=G, rho=7850.0, y_axis=ey)
    model = assemble_beam(polyline_mesh([p0, p0 + L * ex], n_el), sec, "cantilever")
    s = np.linspace(0.0, L, n_el + 1)  # arc length of the nodes
    return model, sec, L, s, (ex, ey, ez)


def test_cantilever_tip_force_and_moment(oblique_cantilever):
    model, sec, L, s, (ex, ey, ez) = oblique_cantilever
    P, Mz, N, T = 850.0, 120.0, 3.0e4, 75.0
    tip = len(s) - 1
    zero = np.zeros(3)
    cases = {
        # tip force along local z: w(s) = P s^2 (3L - s) / (6 E Iy), theta = -w' e_y
        "force_z": (np.r_[P * ez, zero],
                    np.outer(P * s**2 * (3 * L - s) / (6 * E * sec.Iy), ez),
                    np.outer(-P * s * (2 * L - s) / (2 * E * sec.Iy), ey)),
        # tip moment about local z: v(s) = M s^2 / (2 E Iz), theta = M s / (E Iz) e_z
        "moment_z": (np.r_[zero, Mz * ez],
                     np.outer(Mz * s**2 / (2 * E * sec.Iz), ey),
                     np.outer(Mz * s / (E * sec.Iz), ez)),
        "axial": (np.r_[N * ex, zero], np.outer(N * s / (E * sec.A), ex), np.zeros((len(s), 3))),
        "torque": (np.r_[zero, T * ex], np.zeros((len(s), 3)), np.outer(T * s / (G * sec.J), ex)),
    }
    for name, (load, u_ref, th_ref) in cases.items():
        d = solve_clamped(model, 0, {tip: load})
        scale_u = max(np.abs(u_ref).max(), 1e-30)
        scale_t = max(np.abs(th_ref).max(), 1e-30)
        assert np.abs(d[:, :3] - u_ref).max() < 1e-9 * max(scale_u, scale_t * L), name
        assert np.abs(d[:, 3:] - th_ref).max() < 1e-9 * max(scale_t, scale_u / L), name
    # the textbook tip formulas themselves
    d = solve_clamped(model, 0, {tip: cases["force_z"][0]})
    assert d[tip, :3] @ ez == pytest.approx(P * L**3 / (3 * E * sec.Iy), rel=1e-10)
    d = solve_clamped(model, 0, {tip: cases["moment_z"][0]})
    assert d[tip, :3] @ ey == pytest.approx(Mz * L**2 / (2 * E * sec.Iz), rel=1e-10)


def test_l_frame_tip_deflection_castigliano():
    """L frame A -> B (length a, along Q e_x) -> C (length b, along Q e_y),
    clamped at A, rotated by Q. Unit-load method (Euler-Bernoulli, axial, torsion):

    out-of-plane P at C:  d_z = P (a^3 / 3EIy1 + b^3 / 3EIy2 + a b^2 / GJ1)
                          (the last term is the twist of member 1 times b);
    in-plane P along e_x: d_x = P (a / EA1 + b^3 / 3EIz2 + a b^2 / EIz1),
                          d_y = -P a^2 b / (2 E Iz1), d_z = 0.
    Member frames: member 1 y = Q e_y, member 2 y = -Q e_x, so both have z = Q e_z.
    """
    a, b, P = 1.5, 1.0, 1000.0
    Q = Rotation.from_euler("zyx", [25.0, -40.0, 15.0], degrees=True).as_matrix()
    X, Y, Z = Q.T
    s1 = BeamSection(A=2e-3, Iy=3e-6, Iz=1.5e-6, J=2e-6, E=E, G=G, rho=7850.0, y_axis=Y)
    s2 = BeamSection(A=1e-3, Iy=1e-6, Iz=0.5e-6, J=0.8e-6, E=E, G=G, rho=7850.0, y_axis=-X)
    n = 6
    mesh = polyline_mesh([np.zeros(3), a * X, a * X + b * Y], n)
    model = assemble_beam(mesh, [s1] * n + [s2] * n, "frame")
    tip = 2 * n
    zero = np.zeros(3)

    d = solve_clamped(model, 0, {tip: np.r_[P * Z, zero]})[tip, :3]
    dz = P * (a**3 / (3 * E * s1.Iy) + b**3 / (3 * E * s2.Iy) + a * b**2 / (G * s1.J))
    np.testing.assert_allclose(d, dz * Z, rtol=0, atol=1e-10 * dz)

    d = solve_clamped(model, 0, {tip: np.r_[P * X, zero]})[tip, :3]
    dx = P * (a / (E * s1.A) + b**3 / (3 * E * s2.Iz) + a * b**2 / (E * s1.Iz))
    dy = -P * a**2 * b / (2 * E * s1.Iz)
    np.testing.assert_allclose(d, dx * X + dy * Y, rtol=0, atol=1e-10 * dx)
