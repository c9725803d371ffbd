"""Cantilever frequencies of a P2 solid bar against closed-form beam theory.

References (independent of the FE code):
* bending, Euler-Bernoulli clamped-free: omega = (beta L)^2 / L^2 sqrt(E I / (rho A)),
  beta L = 1.8751, 4.6941, 7.8548;
* torsion, Saint-Venant clamped-free: omega = pi / (2 L) sqrt(G J / (rho Ip)) with the
  series torsion constant of a rectangle and Ip = b h (b^2 + h^2) / 12.
The bar is slender (L / b = 83), so shear, rotary inertia and warping restraint
at the clamp stay well below the tolerances.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from pipeline.fem import Material, assemble_solid
from pipeline.meshing.mesh_data import MeshData

L, B, H = 0.5, 0.006, 0.004  # m; B along y, H along z
ALUMINIUM = Material(E=70e9, nu=0.33, rho=2700.0)
BETA_L = np.array([1.8750410407, 4.6940911330, 7.8547574382])


def bar_mesh(nx: int, ny: int, nz: int) -> MeshData:
    from skfem import MeshTet

    m = MeshTet.init_tensor(np.linspace(0, L, nx + 1), np.linspace(-B / 2, B / 2, ny + 1),
                            np.linspace(-H / 2, H / 2, nz + 1))
    return MeshData(m.p.T, {"tetra": m.t.T}, "solid")


def bending_hz(second_moment: float) -> np.ndarray:
    E, rho = ALUMINIUM.E, ALUMINIUM.rho
    return BETA_L**2 / L**2 * np.sqrt(E * second_moment / (rho * B * H)) / (2 * np.pi)


def torsion_hz() -> float:
    a, t = max(B, H), min(B, H)
    n = np.arange(1, 400, 2)
    J = a * t**3 * (1 / 3 - 64 / np.pi**5 * (t / a) * np.sum(np.tanh(n * np.pi * a / (2 * t)) / n**5))
    Ip = B * H * (B**2 + H**2) / 12
    return np.pi / (2 * L) * np.sqrt(ALUMINIUM.shear_modulus * J / (ALUMINIUM.rho * Ip)) / (2 * np.pi)


def clamped_modes(model, k: int):
    """Frequencies (Hz), component kinetic-energy fractions (k, 3) and twist
    correlation (k,) of the modes clamped at x = 0.

    The twist correlation is the M-inner-product cosine^2 between a mode and
    the rotation field about the bar axis (0, -z, y): ~0 for bending and
    axial modes (symmetric section), ~0.8 for the first torsion mode.
    """
    fixed = model.node_dofs[np.flatnonzero(model.nodes[:, 0] < 1e-12)].ravel()
    free = np.setdiff1d(np.arange(model.n_dof), fixed)
    K, M = model.stiffness[free][:, free], model.mass[free][:, free]
    # Shift-invert at 0 with a symmetric fill-reducing ordering (much less fill than COLAMD).
    lu = sla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A")
    OPinv = sla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    w2, V = sla.eigsh(K, k, M, sigma=0.0, OPinv=OPinv)
    U = np.zeros((model.n_dof, k))
    U[free] = V
    Ms = model.extras["scalar_mass"]
    comp = np.array([[U[model.node_dofs[:, c], j] @ (Ms @ U[model.node_dofs[:, c], j])
                      for c in range(3)] for j in range(k)])
    rot = np.zeros(model.n_dof)
    rot[model.node_dofs[:, 1]] = -model.nodes[:, 2]
    rot[model.node_dofs[:, 2]] = model.nodes[:, 1]
    M = model.mass
    twist = (rot @ (M @ U)) ** 2 / (np.einsum("ij,ij->j", U, M @ U) * (rot @ (M @ rot)))
    return np.sqrt(w2) / (2 * np.pi), comp / comp.sum(axis=1, keepdims=True), twist


def classified(freqs, fractions, twist):
    """Bending in y, bending in z (first three each) and the torsion modes."""
    in_y = freqs[(fractions[:, 1] > 0.95) & (twist < 0.05)][:3]
    in_z = freqs[(fractions[:, 2] > 0.95) & (twist < 0.05)][:3]
    return in_y, in_z, freqs[twist > 0.5]


@pytest.mark.parametrize("mesh_div, tol_bend, tol_twist", [
    ((50, 3, 3), 0.005, 0.02),
    pytest.param((100, 4, 4), 0.003, 0.006, marks=pytest.mark.slow),
])
def test_cantilever_bending_and_torsion(mesh_div, tol_bend, tol_twist):
    model = assemble_solid(bar_mesh(*mesh_div), ALUMINIUM, "bar")
    in_y, in_z, twist = classified(*clamped_modes(model, 14))
    ref_y, ref_z = bending_hz(H * B**3 / 12), bending_hz(B * H**3 / 12)
    err_y, err_z = in_y / ref_y - 1, in_z / ref_z - 1
    err_t = twist[0] / torsion_hz() - 1
    print(f"\n{mesh_div}: {model.n_dof} DOF; bending-y errors {np.round(100 * err_y, 3)} %, "
          f"bending-z {np.round(100 * err_z, 3)} %, torsion {100 * err_t:.3f} %")
    assert in_y.size == 3 and in_z.size == 3 and twist.size >= 1
    assert np.all(np.abs(err_y) < tol_bend) and np.all(np.abs(err_z) < tol_bend)
    assert abs(err_t) < tol_twist


def test_p1_locks_where_p2_does_not():
    """P1 tetrahedra (skfem, same mesh) are far too stiff in bending; P2 is not."""
    from skfem import Basis, BilinearForm, ElementTetP1, ElementVector, MeshTet, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity

    mesh = bar_mesh(40, 2, 2)
    p2 = assemble_solid(mesh, ALUMINIUM, "bar")
    f2, frac2, _ = clamped_modes(p2, 2)
    basis = Basis(MeshTet(mesh.points.T, mesh.cells["tetra"].T), ElementVector(ElementTetP1()))

    @BilinearForm
    def mass(u, v, w):
        return ALUMINIUM.rho * dot(u, v)

    K = asm(linear_elasticity(*ALUMINIUM.lame), basis)
    M = asm(mass, basis)
    free = basis.complement_dofs(basis.get_dofs(lambda x: x[0] < 1e-12))
    w2 = sla.eigsh(K[free][:, free], 1, M[free][:, free], sigma=0.0, return_eigenvectors=False)
    ref = bending_hz(B * H**3 / 12)[0]
    err_p1 = np.sqrt(w2.min()) / (2 * np.pi) / ref - 1
    err_p2 = f2[0] / ref - 1
    print(f"\nfirst bending: P1 error {100 * err_p1:.1f} %, P2 error {100 * err_p2:.2f} %")
    assert frac2[0, 2] > 0.95
    assert err_p1 > 0.2 and abs(err_p2) < 0.005
