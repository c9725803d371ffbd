"""Test models for the modes tests, built with scikit-fem directly.

Independent of ``pipeline.fem.solid``: P2 tetrahedra (ElementVector(ElementTetP2))
on a structured box mesh, skfem's own ``linear_elasticity`` and ``mass`` forms,
wrapped in a FemModel (nodes = vertices, then edge midpoints).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.fem.model import FemModel

STEEL = {"E": 210e9, "nu": 0.3, "rho": 7850.0}


@functools.lru_cache(maxsize=8)
def box_model(L: float = 0.4, b: float = 0.02, h: float = 0.01, nx: int = 16, ny: int = 2,
              nz: int = 2, E: float = STEEL["E"], nu: float = STEEL["nu"],
              rho: float = STEEL["rho"], name: str = "bar") -> FemModel:
    """Free-free P2 model of the box [0, L] x [0, b] x [0, h] (m)."""
    from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, MeshTet
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = MeshTet.init_tensor(np.linspace(0, L, nx + 1), np.linspace(0, b, ny + 1),
                               np.linspace(0, h, nz + 1))
    basis = Basis(mesh, ElementVector(ElementTetP2()))

    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)

    K = linear_elasticity(*lame_parameters(E, nu)).assemble(basis).tocsr()
    M = mass.assemble(basis).tocsr()
    nodes = np.vstack([mesh.p.T, mesh.p[:, mesh.edges].mean(axis=1).T])
    node_dofs = np.vstack([basis.nodal_dofs.T, basis.edge_dofs.T])
    bf = mesh.boundary_facets()
    boundary = np.union1d(np.unique(mesh.facets[:, bf]),
                          mesh.p.shape[1] + np.unique(mesh.f2e[:, bf]))
    return FemModel(name, "solid", nodes, node_dofs, K, M,
                    {"boundary_nodes": boundary})


@pytest.fixture(scope="session")
def bar() -> FemModel:
    """Steel bar 0.4 x 0.02 x 0.01 m, 16 x 2 x 2 hexes split into P2 tets (~2.4k DOFs)."""
    return box_model()


def dirichlet_modes(model: FemModel, fixed_nodes: np.ndarray, k: int):
    """Reference: eliminate all DOFs of ``fixed_nodes`` and solve densely."""
    import scipy.linalg as la

    fixed = model.node_dofs[fixed_nodes].ravel()
    free = np.setdiff1d(np.arange(model.n_dof), fixed)
    K = model.stiffness[free][:, free].toarray()
    M = model.mass[free][:, free].toarray()
    lam, X = la.eigh(K, M, subset_by_index=[0, k - 1])
    return lam, X, free


def rigid_lstsq(x: np.ndarray, origin: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Independent least-squares rigid fit: [t; theta] minimising |u - t - theta x r|.

    x (k, 3) node coordinates, u (k, 3) displacements; numpy lstsq on the
    stacked (3k, 6) system written out component by component.
    """
    r = x - origin
    k = r.shape[0]
    A = np.zeros((3 * k, 6))
    for i in range(3):
        A[i::3, i] = 1.0
    # theta x r = (ty rz - tz ry, tz rx - tx rz, tx ry - ty rx)
    A[0::3, 4], A[0::3, 5] = r[:, 2], -r[:, 1]
    A[1::3, 3], A[1::3, 5] = -r[:, 2], r[:, 0]
    A[2::3, 3], A[2::3, 4] = r[:, 1], -r[:, 0]
    sol, *_ = np.linalg.lstsq(A, u.reshape(-1), rcond=None)
    return sol


def as_csr(A) -> sp.csr_matrix:
    return sp.csr_matrix(A)
