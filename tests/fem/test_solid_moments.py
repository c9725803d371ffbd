"""Mass-distribution matrices of P2 solids against closed forms and against the
model's own mass matrix (tr(C''_ab) = U_a^T M U_b, rigid-motion consistency)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.fem import Material, assemble_solid, mass_moments, solid_moments
from pipeline.meshing.mesh_data import MeshData

RHO = 2700.0
DIMS = np.array([0.3, 0.12, 0.05])  # box edge lengths, m
OFFSET = np.array([0.4, -0.25, 0.1])  # m


def rotation(angles) -> np.ndarray:
    a, b, c = angles
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


R_BOX = rotation([0.3, -0.5, 0.9])


def box_model(quadratic: bool = False):
    """Rotated, offset box x = R_BOX s + OFFSET, s in [0, DIMS]; tetra or tetra10."""
    from skfem import MeshTet, MeshTet2

    m = MeshTet.init_tensor(*[np.linspace(0, d, n) for d, n in zip(DIMS, (5, 3, 2))])
    if quadratic:
        m2 = MeshTet2.from_mesh(m)
        nv = m2.nvertices
        cells = np.vstack([m2.t, nv + m2.t2e]).T
        pts = m2.doflocs.T @ R_BOX.T + OFFSET
        mesh = MeshData(pts, {"tetra10": cells}, "solid", order=2)
    else:
        mesh = MeshData(m.p.T @ R_BOX.T + OFFSET, {"tetra": m.t.T}, "solid")
    return assemble_solid(mesh, Material(70e9, 0.33, RHO), "box")


def box_closed_form() -> np.ndarray:
    """C = int rho r r^T dV of the rotated, offset box (4, 4)."""
    m = RHO * DIMS.prod()
    c = R_BOX @ (DIMS / 2) + OFFSET
    S = R_BOX @ np.diag(m * DIMS**2 / 12) @ R_BOX.T + m * np.outer(c, c)
    C = np.zeros((4, 4))
    C[:3, :3], C[:3, 3], C[3, :3], C[3, 3] = S, m * c, m * c, m
    return C


def rigid_fields(model) -> np.ndarray:
    """(n_dof, 6) DOF vectors of unit translations and rotations about the origin."""
    R = np.zeros((model.n_dof, 6))
    for a in range(3):
        R[model.node_dofs[:, a], a] = 1.0
        R[model.node_dofs, 3 + a] = np.cross(np.eye(3)[a], model.nodes)
    return R


@pytest.mark.parametrize("quadratic", [False, True])
def test_box_mass_centre_and_inertia(quadratic):
    model = box_model(quadratic)
    C = mass_moments(model, np.zeros((model.n_dof, 0))).C
    ref = box_closed_form()
    mass, centre = C[3, 3], C[:3, 3] / C[3, 3]
    S = C[:3, :3]
    inertia = np.trace(S) * np.eye(3) - S
    S_ref = ref[:3, :3]
    inertia_ref = np.trace(S_ref) * np.eye(3) - S_ref
    assert mass == pytest.approx(ref[3, 3], rel=1e-12)
    np.testing.assert_allclose(centre, ref[:3, 3] / ref[3, 3], rtol=1e-12)
    np.testing.assert_allclose(inertia, inertia_ref, rtol=0, atol=1e-10 * np.abs(inertia_ref).max())
    off_diagonal = np.abs(inertia_ref[np.triu_indices(3, 1)])
    assert off_diagonal.min() > 0.05 * np.abs(inertia_ref).max()  # all entries non-trivial
    # Mass from the vector mass matrix: translation fields.
    T = rigid_fields(model)[:, :3]
    np.testing.assert_allclose(T.T @ model.mass @ T, ref[3, 3] * np.eye(3), rtol=1e-12, atol=1e-9)


def test_modal_mass_first_and_second_moments_from_mass_matrix():
    model = box_model()
    U = np.random.default_rng(3).standard_normal((model.n_dof, 5))
    mm = solid_moments(model, U)
    MU = model.mass @ U
    scale = np.abs(U.T @ MU).max()
    traces = np.einsum("abkk->ab", mm.Cpp)
    np.testing.assert_allclose(traces, U.T @ MU, rtol=0, atol=1e-12 * scale)
    R = rigid_fields(model)
    # C'_a[3, k] = int rho phi_a^(k) dV = (unit translation k)^T M U_a.
    np.testing.assert_allclose(mm.Cp[:, 3, :3], (R[:, :3].T @ MU).T, rtol=0, atol=1e-12 * scale)
    # C'_a[i, k] = int rho x_i phi_a^(k) dV = (field x_i e_k)^T M U_a.
    for i in range(3):
        for k in range(3):
            f = np.zeros(model.n_dof)
            f[model.node_dofs[:, k]] = model.nodes[:, i]
            np.testing.assert_allclose(mm.Cp[:, i, k], f @ MU, rtol=0, atol=1e-12 * scale)
    assert np.all(mm.Cp[:, :, 3] == 0) and np.all(mm.Cpp[:, :, 3, :] == 0)


@pytest.mark.parametrize("quadratic", [False, True])
def test_rigid_motion_moments_are_the_moved_C(quadratic):
    """For u = t + theta x r: r + eta u = A(eta) r, so C'_a = C A1^T, C''_aa = A1 C A1^T."""
    model = box_model(quadratic)
    theta, t = np.array([0.2, -0.7, 0.4]), np.array([0.05, 0.3, -0.1])
    u = t + np.cross(theta, model.nodes)
    U = np.zeros((model.n_dof, 1))
    U[model.node_dofs, 0] = u
    mm = solid_moments(model, U)
    A1 = np.zeros((4, 4))
    A1[:3, :3] = np.array([[0, -theta[2], theta[1]], [theta[2], 0, -theta[0]],
                           [-theta[1], theta[0], 0]])
    A1[:3, 3] = t
    C = mm.C
    scale = np.abs(C).max()
    np.testing.assert_allclose(mm.Cp[0], C @ A1.T, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(mm.Cpp[0, 0], A1 @ C @ A1.T, rtol=0, atol=1e-12 * scale)
