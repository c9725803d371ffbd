"""Beam mass-distribution matrices C, C'_a, C''_ab vs independent references."""

import numpy as np
import pytest
from beam_meshes import polyline_mesh

from pipeline.fem.beam import assemble_beam, beam_moments
from pipeline.fem.moments import mass_moments
from pipeline.fem.section import BeamSection

E, G, RHO = 2.1e11, 8.1e10, 7850.0


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def frame(e_x, y_axis):
    if y_axis is None:
        hint = np.cross([0.0, 0.0, 1.0], e_x)
        hint = hint if np.linalg.norm(hint) > 1e-6 else np.array([0.0, 1.0, 0.0])
    else:
        hint = np.asarray(y_axis, float)
    ey = hint - hint @ e_x * e_x
    ey /= np.linalg.norm(ey)
    return np.array([e_x, ey, np.cross(e_x, ey)])


@pytest.fixture(scope="module")
def boom():
    """Kinked three-member boom, different sections, one with its own y axis."""
    n = 5
    mesh = polyline_mesh([[0.1, -0.2, 0.3], [4.0, 0.0, 6.9], [8.1, 0.4, 13.8],
                          [12.0, 0.2, 20.8]], n)
    secs = [BeamSection(A=0.0183, Iy=6.0e-4, Iz=4.0e-4, J=8e-4, E=E, G=G, rho=RHO),
            BeamSection(A=0.0152, Iy=4.5e-4, Iz=2.0e-4, J=5e-4, E=E, G=G, rho=RHO,
                        y_axis=(0.3, 0.2, 1.0)),
            BeamSection(A=0.0120, Iy=3.0e-4, Iz=2.5e-4, J=4e-4, E=E, G=G, rho=2700.0)]
    per_element = [secs[e // n] for e in range(3 * n)]
    return assemble_beam(mesh, per_element, "boom"), per_element


def reference_moments(model, sections, U, n_gauss=6):
    """Element loop with its own fields: each transverse cubic is found by
    solving the 4x4 Hermite conditions (value and slope at both ends) in the
    member's arc length s; axial and torsion linear; theta_z = v', theta_y = -w'."""
    pts, cells = model.nodes, model.extras["cells"]
    xg, wg = np.polynomial.legendre.leggauss(n_gauss)
    m = U.shape[1]
    C, Cp, Cpp = np.zeros((4, 4)), np.zeros((m, 4, 4)), np.zeros((m, m, 4, 4))
    for (i, j), sec in zip(cells, sections):
        L = np.linalg.norm(pts[j] - pts[i])
        R = frame((pts[j] - pts[i]) / L, sec.y_axis)
        S = sec.rho * (sec.Iz * np.outer(R[1], R[1]) + sec.Iy * np.outer(R[2], R[2]))
        V = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [1, L, L**2, L**3], [0, 1, 2 * L, 3 * L**2]])
        uloc = [[R @ U[model.node_dofs[nd, :3], a] for nd in (i, j)] for a in range(m)]
        tloc = [[R @ U[model.node_dofs[nd, 3:], a] for nd in (i, j)] for a in range(m)]
        cv = [np.linalg.solve(V, [u[0][1], t[0][2], u[1][1], t[1][2]]) for u, t in zip(uloc, tloc)]
        cw = [np.linalg.solve(V, [u[0][2], -t[0][1], u[1][2], -t[1][1]])
              for u, t in zip(uloc, tloc)]
        for xq, wq in zip(xg, wg):
            s, ds = 0.5 * L * (xq + 1), 0.5 * L * wq
            x = np.append(pts[i] + s / L * (pts[j] - pts[i]), 1.0)
            powers, dpowers = np.array([1, s, s**2, s**3]), np.array([0, 1, 2 * s, 3 * s**2])
            phi, th = [], []
            for a in range(m):
                lin = lambda f: f[0] + s / L * (f[1] - f[0])
                u_l = [lin([uloc[a][0][0], uloc[a][1][0]]), cv[a] @ powers, cw[a] @ powers]
                t_l = [lin([tloc[a][0][0], tloc[a][1][0]]), -(cw[a] @ dpowers), cv[a] @ dpowers]
                phi.append(np.append(R.T @ u_l, 0.0))
                th.append(R.T @ t_l)
            C += ds * (sec.rho * sec.A * np.outer(x, x))
            C[:3, :3] += ds * S
            for a in range(m):
                Cp[a] += ds * sec.rho * sec.A * np.outer(x, phi[a])
                Cp[a, :3, :3] -= ds * S @ skew(th[a])
                for b in range(m):
                    Cpp[a, b] += ds * sec.rho * sec.A * np.outer(phi[a], phi[b])
                    Cpp[a, b, :3, :3] += ds * skew(th[a]) @ S @ skew(th[b]).T
    return C, Cp, Cpp


def rel_err(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def test_straight_oblique_beam_mass_centre_inertia():
    """C of a uniform straight beam p0 -> p0 + L e: m = rho A L, centre at the
    midpoint, inertia about the centre = rho A L^3 / 12 (1 - e e^T) + L rho
    ((Iy + Iz) e e^T + Iy e_y e_y^T + Iz e_z e_z^T) (rod + section rotary inertia)."""
    p0, L = np.array([1.2, -0.7, 0.4]), 3.0
    e = np.array([2.0, -1.0, 2.0]) / 3.0
    sec = BeamSection(A=4e-3, Iy=5e-5, Iz=2e-5, J=6e-5, E=E, G=G, rho=RHO)
    model = assemble_beam(polyline_mesh([p0, p0 + L * e], 7), sec, "rod")
    C = mass_moments(model, np.zeros((model.n_dof, 0))).C
    m = RHO * sec.A * L
    c = p0 + 0.5 * L * e
    R = frame(e, None)
    I_ref = (m * L**2 / 12 * (np.eye(3) - np.outer(e, e))
             + L * RHO * ((sec.Iy + sec.Iz) * np.outer(e, e) + sec.Iy * np.outer(R[1], R[1])
                          + sec.Iz * np.outer(R[2], R[2])))
    assert C[3, 3] == pytest.approx(m, rel=1e-13)
    np.testing.assert_allclose(C[:3, 3] / C[3, 3], c, rtol=1e-13)
    np.testing.assert_allclose(C[3, :3], C[:3, 3], rtol=0, atol=0)
    S_c = C[:3, :3] - np.outer(C[:3, 3], C[:3, 3]) / C[3, 3]
    I = np.trace(S_c) * np.eye(3) - S_c
    assert rel_err(I, I_ref) < 1e-10


def test_modal_mass_equals_mass_matrix(boom):
    model, _ = boom
    U = np.random.default_rng(7).standard_normal((model.n_dof, 4))
    mm = beam_moments(model, U)
    UMU = U.T @ model.mass @ U
    assert rel_err(np.trace(mm.Cpp, axis1=2, axis2=3), UMU) < 1e-12
    np.testing.assert_array_equal(mm.Cpp, mm.Cpp.transpose(1, 0, 3, 2))
    assert np.all(mm.Cp[:, :, 3] == 0) and np.all(mm.Cpp[:, :, 3, :] == 0)


def test_first_moment_row_equals_rigid_translations_times_mass(boom):
    """C'_a[3, :3] = int rho phi_a = T_k^T M U_a, T_k the unit translation along k."""
    model, _ = boom
    U = np.random.default_rng(8).standard_normal((model.n_dof, 3))
    T = np.zeros((model.n_dof, 3))
    for k in range(3):
        T[model.node_dofs[:, k], k] = 1.0
    Cp = beam_moments(model, U).Cp
    assert rel_err(Cp[:, 3, :3], (T.T @ model.mass @ U).T) < 1e-12


def test_against_element_loop_reference(boom):
    model, sections = boom
    U = np.random.default_rng(9).standard_normal((model.n_dof, 3))
    mm = beam_moments(model, U)
    C, Cp, Cpp = reference_moments(model, sections, U)
    assert rel_err(mm.C, C) < 1e-12
    assert rel_err(mm.Cp, Cp) < 1e-12
    assert rel_err(mm.Cpp, Cpp) < 1e-12


def test_rigid_motion_fields(boom):
    """Rigid motions are reproduced exactly by the interpolation (linear
    transverse fields with matching end slopes lie in the Hermite space; the
    rotations are constant). With W = [[ [w]x, t ], [0, 0]] every material
    point moves phi = W r (homogeneous r = [x + s; 1]), hence

        C'_a  = int rho r (W_a r)^T = C W_a^T,
        C''_ab = int rho (W_a r)(W_b r)^T = W_a C W_b^T.

    Built here for two small rotations about the origin (u = w x x,
    theta = w) and one translation."""
    model, _ = boom
    rng = np.random.default_rng(10)
    motions = [(rng.standard_normal(3), np.zeros(3)), (rng.standard_normal(3), np.zeros(3)),
               (np.zeros(3), rng.standard_normal(3))]
    U = np.zeros((model.n_dof, 3))
    W = np.zeros((3, 4, 4))
    for a, (w, t) in enumerate(motions):
        U[model.node_dofs[:, :3], a] = np.cross(w, model.nodes) + t
        U[model.node_dofs[:, 3:], a] = w
        W[a, :3, :3], W[a, :3, 3] = skew(w), t
    mm = beam_moments(model, U)
    assert rel_err(mm.Cp, np.einsum("ij,akj->aik", mm.C, W)) < 1e-12
    assert rel_err(mm.Cpp, np.einsum("aij,jk,blk->abil", W, mm.C, W)) < 1e-12


def test_beam_with_point_masses_through_mass_moments(boom):
    """The dispatch in mass_moments adds point bodies to the beam kernel: the
    seed's lumped boom masses (1150, 952, 752 kg at the member ends) keep
    tr(C''_ab) = U_a^T M U_b and add m p to the first moment."""
    from pipeline.fem.point_masses import PointMass, add_point_masses

    model, _ = boom
    ends = model.nodes[[5, 10, 15]]
    bodies = [PointMass(f"m{i}", p + [0.0, 0.0, 0.3], m, np.diag([10.0, 12.0, 15.0]))
              for i, (p, m) in enumerate(zip(ends, (1150.0, 952.0, 752.0)))]
    loaded = add_point_masses(model, bodies, "link 'boom'")
    U = np.random.default_rng(11).standard_normal((model.n_dof, 3))
    mm = mass_moments(loaded, U)
    assert rel_err(np.trace(mm.Cpp, axis1=2, axis2=3), U.T @ loaded.mass @ U) < 1e-12
    bare = beam_moments(model, U).C
    first = sum(b.mass * np.append(b.position, 1.0) for b in bodies)
    np.testing.assert_allclose(mm.C[:, 3] - bare[:, 3], first, rtol=1e-12)
