"""Mass-distribution matrices (DESIGN §2) from the model's own mass operator.

With homogeneous position r = [x, y, z, 1] and mode field phi_a = [phi, 0]::

    C       = int rho r r^T dV          (4, 4)
    C'_a    = int rho r phi_a^T dV      (m, 4, 4)
    C''_ab  = int rho phi_a phi_b^T dV  (m, m, 4, 4)

Each element family provides a kernel registered in :data:`MOMENT_KERNELS`
(``"module:function"``, imported lazily) with the signature
``kernel(model, U) -> MassMoments`` for its distributed mass; attached point
masses (``model.extras["point_masses"]``) are added here, identically for all
families, so that tr(C''_ab) = U_a^T M U_b holds exactly.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from pipeline.fem.model import FemModel
from pipeline.fem.rigid_fit import skew

MOMENT_KERNELS: dict[str, str] = {
    "solid": "pipeline.fem.solid:solid_moments",
    "beam": "pipeline.fem.beam:beam_moments",
}


@dataclass(frozen=True)
class MassMoments:
    """C (4, 4) in kg, kg m, kg m^2; Cp (m, 4, 4); Cpp (m, m, 4, 4)."""

    C: np.ndarray
    Cp: np.ndarray
    Cpp: np.ndarray

    def __add__(self, other: MassMoments) -> MassMoments:
        return MassMoments(self.C + other.C, self.Cp + other.Cp, self.Cpp + other.Cpp)


def mass_moments(model: FemModel, U: np.ndarray) -> MassMoments:
    """Mass-distribution matrices of ``model`` for the DOF vectors ``U``.

    Parameters
    ----------
    model : FemModel
        Free-free model (its ``mass`` includes the point masses).
    U : (n_dof, m) array
        Mode shapes (any DOF vectors) in the model's DOF numbering.

    Returns
    -------
    MassMoments
    """
    U = np.asarray(U, float).reshape(model.n_dof, -1)
    module, func = MOMENT_KERNELS[model.kind].split(":")
    kernel = getattr(importlib.import_module(module), func)
    moments = kernel(model, U)
    for pm in model.extras.get("point_masses", ()):
        moments = moments + point_mass_moments(pm["mass"], pm["second_moment"],
                                               pm["position"], pm["operator"], U)
    return moments


def point_mass_moments(mass: float, second_moment: np.ndarray, position: np.ndarray,
                       operator, U: np.ndarray) -> MassMoments:
    """Moments of a rigid point body attached through a (6, n_dof) operator.

    The body (mass kg, second moment S = int rho s s^T about its centre, kg m^2)
    moves with t + theta x s where [t; theta] = operator @ u. Its mass-matrix
    contribution is operator^T diag(m 1, tr(S) 1 - S) operator.
    """
    p = np.append(np.asarray(position, float), 1.0)
    S4 = np.zeros((4, 4))
    S4[:3, :3] = second_moment
    C = mass * np.outer(p, p) + S4
    motion = np.asarray(operator @ U).T  # (m, 6)
    t = np.zeros((motion.shape[0], 4))
    t[:, :3] = motion[:, :3]
    rot = np.array([skew(th) for th in motion[:, 3:]]).reshape(-1, 3, 3)
    Cp = mass * np.einsum("i,aj->aij", p, t)
    Cp[:, :3, :3] -= np.einsum("ij,ajk->aik", second_moment, rot)
    Cpp = mass * np.einsum("ai,bj->abij", t, t)
    Cpp[:, :, :3, :3] += np.einsum("aij,jk,blk->abil", rot, second_moment, rot)
    return MassMoments(C, Cp, Cpp)
