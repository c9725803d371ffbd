"""Mass-distribution matrices of a beam model (the kernel behind ``mass_moments``).

A material point of the beam is ``x + s`` (``x`` on the centreline, ``s`` in
the section, int rho s dA = 0) and moves with ``u + theta x s``. Integrating
over the section, with ``S_sec = rho (Iz e_y e_y^T + Iy e_z e_z^T)`` per unit
length (link frame) and homogeneous ``r = [x; 1]``::

    C      = int rho A r r^T dx + int [[S_sec, 0], [0, 0]] dx
    C'_a   = int rho A r [u_a; 0]^T dx + int [[-S_sec [theta_a]x, 0], [0, 0]] dx
    C''_ab = int rho A [u_a; 0][u_b; 0]^T dx
             + int [[[theta_a]x S_sec [theta_b]x^T, 0], [0, 0]] dx

``u`` and ``theta`` are interpolated exactly as in the mass matrix of
:func:`pipeline.fem.beam.assemble_beam` (P1 axial and torsion, Hermite
transverse, bending rotations the derivatives of the Hermite fields) and the
integrals use Gauss quadrature exact for them, so
``tr(C''_ab) = U_a^T M U_b`` to rounding.
"""

from __future__ import annotations

import numpy as np

from pipeline.fem.model import FemModel
from pipeline.fem.moments import MassMoments

__all__ = ["beam_fields", "beam_moments"]

# 4 Gauss points integrate degree 7 exactly; the highest integrand is
# (cubic transverse)^2 = degree 6.
GAUSS_POINTS = 4


def beam_moments(model: FemModel, U: np.ndarray) -> MassMoments:
    """C, C'_a, C''_ab of the distributed beam mass (point masses excluded).

    Parameters
    ----------
    model : FemModel
        Produced by :func:`pipeline.fem.beam.assemble_beam` (``kind="beam"``).
    U : (n_dof, m) array
        DOF vectors (mode shapes) in the model's numbering; m, rad.

    Returns
    -------
    MassMoments
        ``C`` (4, 4) kg, kg m, kg m^2; ``Cp`` (m, 4, 4); ``Cpp`` (m, m, 4, 4).

    Examples
    --------
    >>> from pipeline.fem.beam import assemble_beam
    >>> from pipeline.fem.section import BeamSection
    >>> from pipeline.meshing.mesh_data import MeshData
    >>> mesh = MeshData(points=[[0, 0, 0], [2, 0, 0]], cells={"line": [[0, 1]]}, kind="beam")
    >>> s = BeamSection(A=1e-4, Iy=1e-9, Iz=1e-9, J=2e-9, E=2e11, G=8e10, rho=7800.0)
    >>> C = beam_moments(assemble_beam(mesh, s, "bar"), np.zeros((12, 1))).C
    >>> round(float(C[3, 3]), 12), round(float(C[0, 3] / C[3, 3]), 12)   # mass, centre x
    (1.56, 1.0)
    """
    U = np.asarray(U, dtype=float).reshape(model.n_dof, -1)
    xi, wq = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    xi, wq = 0.5 * (xi + 1.0), 0.5 * wq
    x, u, theta = beam_fields(model, U, xi)
    A, Iy, Iz, rho = (model.extras["sections"][:, i] for i in (0, 1, 2, 6))
    frames, lengths = model.extras["frames"], model.extras["lengths"]
    dx = lengths[:, None] * wq[None, :]  # (k, g) m
    mass_dx = (rho * A)[:, None] * dx  # (k, g) kg
    lam = np.stack([rho * Iz, rho * Iy], axis=1)  # (k, 2) kg/m, along e_y, e_z
    e_yz = frames[:, 1:, :]  # (k, 2, 3)

    r = np.concatenate([x, np.ones(x.shape[:2] + (1,))], axis=2)  # (k, g, 4)
    C = np.einsum("kg,kgi,kgj->ij", mass_dx, r, r, optimize=True)
    C[:3, :3] += np.einsum("k,kc,kci,kcj->ij", lengths, lam, e_yz, e_yz, optimize=True)

    m = U.shape[1]
    Cp = np.zeros((m, 4, 4))
    Cp[:, :, :3] = np.einsum("kg,kgi,kgaj->aij", mass_dx, r, u, optimize=True)
    # -S_sec [theta]x = sum_c lam_c e_c (theta x e_c)^T ; [a]x S_sec [b]x^T likewise.
    t_cross_e = np.cross(theta[:, :, :, None, :], e_yz[:, None, None, :, :])  # (k, g, m, 2, 3)
    Cp[:, :3, :3] += np.einsum("kg,kc,kci,kgacj->aij", dx, lam, e_yz, t_cross_e, optimize=True)

    Cpp = np.zeros((m, m, 4, 4))
    Cpp[:, :, :3, :3] = np.einsum("kg,kgai,kgbj->abij", mass_dx, u, u, optimize=True)
    Cpp[:, :, :3, :3] += np.einsum("kg,kc,kgaci,kgbcj->abij", dx, lam, t_cross_e, t_cross_e,
                                   optimize=True)
    # exact symmetries C = C^T, C''_ab = C''_ba^T (einsum orders sum differently)
    C = 0.5 * (C + C.T)
    Cpp = 0.5 * (Cpp + Cpp.transpose(1, 0, 3, 2))
    return MassMoments(C, Cp, Cpp)


def beam_fields(
    model: FemModel, U: np.ndarray, xi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centreline points, displacements and rotations inside every element.

    Parameters
    ----------
    model : FemModel
        Beam model (``extras`` "cells", "frames", "lengths").
    U : (n_dof, m) array
        DOF vectors.
    xi : (g,) array
        Element coordinates in [0, 1] (0 at the element's first node).

    Returns
    -------
    x : (k, g, 3) centreline points, m, link frame.
    u : (k, g, m, 3) displacements, m, link frame.
    theta : (k, g, m, 3) small rotations, rad, link frame.
    """
    cells, frames = model.extras["cells"], model.extras["frames"]
    L = model.extras["lengths"][:, None, None]  # (k, 1, 1) for (k, g, m) fields
    k, m = len(cells), U.shape[1]
    nodal = U[model.node_dofs[cells].reshape(k, 12)].reshape(k, 4, 3, m)
    loc = np.einsum("kij,kajm->kaim", frames, nodal)  # local components
    (u0, t0, u1, t1) = (loc[:, i] for i in range(4))  # each (k, 3, m)
    xi = np.asarray(xi, dtype=float)
    n0, n1 = (1.0 - xi)[None, :, None], xi[None, :, None]
    H, dH = _hermite(xi)

    def cubic(basis, v0, s0, v1, s1):  # v: values, s: slopes d/dx; -> (k, g, m)
        b = [h[None, :, None] for h in basis]
        return (b[0] * v0[:, None] + L * b[1] * s0[:, None]
                + b[2] * v1[:, None] + L * b[3] * s1[:, None])

    u_loc = np.stack([
        n0 * u0[:, None, 0] + n1 * u1[:, None, 0],
        cubic(H, u0[:, 1], t0[:, 2], u1[:, 1], t1[:, 2]),
        cubic(H, u0[:, 2], -t0[:, 1], u1[:, 2], -t1[:, 1]),
    ], axis=-1)
    th_loc = np.stack([
        n0 * t0[:, None, 0] + n1 * t1[:, None, 0],
        -cubic(dH, u0[:, 2], -t0[:, 1], u1[:, 2], -t1[:, 1]) / L,
        cubic(dH, u0[:, 1], t0[:, 2], u1[:, 1], t1[:, 2]) / L,
    ], axis=-1)
    p0 = model.nodes[cells[:, 0]]
    x = p0[:, None, :] + xi[None, :, None] * (model.nodes[cells[:, 1]] - p0)[:, None, :]
    u = np.einsum("kji,kgmj->kgmi", frames, u_loc)
    theta = np.einsum("kji,kgmj->kgmi", frames, th_loc)
    return x, u, theta


def _hermite(xi: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Cubic Hermite shape functions on [0, 1] and their d/dxi (slopes scaled by L)."""
    H = [1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, xi**3 - xi**2]
    dH = [-6 * xi + 6 * xi**2, 1 - 4 * xi + 3 * xi**2, 6 * xi - 6 * xi**2, 3 * xi**2 - 2 * xi]
    return H, dH
