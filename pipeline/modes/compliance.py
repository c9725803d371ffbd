"""Static compliance of a link's frames on the full FE model: what a reduction basis must
reproduce for the loads that enter through its joints.

A unit force (or moment) applied through a frame's motion operator G (its work-conjugate
load, G^T e) and solved on the clamped FE model gives the frame's static deflection; the
matrix of these readings, C = G K_c^-1 G^T, is the full model's flexibility between the
frames. The kept modes reproduce G Phi K_m^-1 Phi^T G^T of it; by Rayleigh-Ritz that never
exceeds C, and the share it reaches tells how much of the link's static flexibility the
basis carries (:mod:`pipeline.invariants.adequacy`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from pipeline.fem.interfaces import Interface, TiedModel, interface_operator
from pipeline.fem.model import FemModel
from pipeline.modes.clamp import ClampedProblem


def _frame_loads(model: FemModel, tied: TiedModel, problem: ClampedProblem,
                 frames: list[Interface], axes: np.ndarray) -> np.ndarray:
    """(n_c, 6F) the frames' unit loads G^T e in the clamped coordinates, body axes."""
    R = np.asarray(axes, dtype=float)
    to_body = sp.block_diag([R.T, R.T] * len(frames), format="csr")
    G = to_body @ sp.vstack([interface_operator(model, f) for f in frames], format="csr")
    expand = tied.transform @ problem.space.L  # clamped coordinates -> full DOFs
    return np.asarray((expand.T @ G.T).todense())


def interface_compliance(model: FemModel, tied: TiedModel, problem: ClampedProblem,
                         frames: list[Interface], axes: np.ndarray) -> np.ndarray:
    """(6F, 6F) static compliance of the clamped FE model between ``frames``.

    Parameters
    ----------
    model : the unreduced FemModel.
    tied : its TiedModel; ``problem`` : the clamped problem of the modes (its reference
        conditions and factorisation, reused: one block solve of 6F right-hand sides).
    frames : F interfaces or marker interfaces (not the reference).
    axes : (3, 3) columns = the body axes in the link frame.

    Returns
    -------
    C : (6F, 6F) symmetric; rows and columns [t_x, t_y, t_z, theta_x, theta_y, theta_z] of
        each frame in body axes; entries m/N, rad/N, m/(N m), rad/(N m).
    """
    if not frames:
        return np.zeros((0, 0))
    loads = _frame_loads(model, tied, problem, frames, axes)  # (n_c, 6F)
    U = np.asarray(problem.factor().solve(loads))
    C = loads.T @ U
    return 0.5 * (C + C.T)


def body_load_response(model: FemModel, tied: TiedModel, problem: ClampedProblem,
                       frames: list[Interface], axes: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The clamped FE model under its own weight: a unit uniform acceleration field along
    each body axis (the body force rho e_k, point masses included,
    :func:`pipeline.fem.geometric.acceleration_loads`; one block solve of 3 right-hand
    sides on the modes' factorisation).

    Returns
    -------
    g : (6F, 3) each frame's static deflection (body axes) per unit acceleration, m and rad
        per m/s^2.
    c : (3, 3) the loads' work on the deflections, f_j . u_k (N m per (m/s^2)^2): the
        compliance of the distributed load, what a basis must carry of a link's own
        weight and inertia.
    """
    from pipeline.fem.geometric import acceleration_loads

    expand = tied.transform @ problem.space.L
    F = np.asarray(expand.T @ acceleration_loads(model, axes).T)  # (n_c, 3)
    U = np.asarray(problem.factor().solve(F))
    c = F.T @ U
    g = _frame_loads(model, tied, problem, frames, axes).T @ U if frames else \
        np.zeros((0, 3))
    return g, 0.5 * (c + c.T)
