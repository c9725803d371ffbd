"""Static compliance of a link's frames on the full FE model: what a reduction basis must
reproduce for the loads that enter through its joints.

A unit force (or moment) applied through a frame's motion operator G (its work-conjugate
load, G^T e) and solved on the clamped FE model gives the frame's static deflection; the
matrix of these readings, C = G K_c^-1 G^T, is the full model's flexibility between the
frames. The kept modes reproduce G Phi K_m^-1 Phi^T G^T of it; by Rayleigh-Ritz that never
exceeds C, and the share it reaches tells how much of the link's static flexibility the
basis carries (:mod:`pipeline.invariants.adequacy`). The link's own weight (a uniform
acceleration field) is solved in the same block: its deflection at the frames and its work.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from pipeline.fem.interfaces import Interface, TiedModel, interface_operator
from pipeline.fem.model import FemModel
from pipeline.modes.clamp import ClampedProblem


def interface_statics(model: FemModel, tied: TiedModel, problem: ClampedProblem,
                      frames: list[Interface], axes: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clamped FE model's static response to the loads a link's frames and its own
    weight put on it: one block solve of 6F + 3 right-hand sides on the modes'
    factorisation.

    Parameters
    ----------
    model : the unreduced FemModel.
    tied : its TiedModel; ``problem`` : the clamped problem of the modes (its reference
        conditions and factorisation, reused).
    frames : F interfaces or marker interfaces (not the reference).
    axes : (3, 3) columns = the body axes in the link frame.

    Returns
    -------
    C : (6F, 6F) symmetric compliance between the frames; rows and columns [t_x, t_y, t_z,
        theta_x, theta_y, theta_z] of each frame in body axes; m/N, rad/N, m/(N m),
        rad/(N m).
    g : (6F, 3) each frame's deflection (body axes) under a unit uniform acceleration along
        each body axis -- the body force rho e_k, point masses included
        (:func:`pipeline.fem.geometric.acceleration_loads`) -- m and rad per m/s^2.
    c : (3, 3) that load's work on its own deflection, f_j . u_k, N m per (m/s^2)^2: the
        compliance of the distributed load, what a basis must carry of the link's own
        weight and inertia.
    """
    from pipeline.fem.geometric import acceleration_loads

    R = np.asarray(axes, dtype=float)
    expand = tied.transform @ problem.space.L  # clamped coordinates -> full DOFs
    weight = np.asarray(expand.T @ acceleration_loads(model, R).T)  # (n_c, 3)
    if frames:
        to_body = sp.block_diag([R.T, R.T] * len(frames), format="csr")
        G = to_body @ sp.vstack([interface_operator(model, f) for f in frames], format="csr")
        loads = np.asarray((expand.T @ G.T).todense())  # (n_c, 6F): G^T e of every direction
    else:
        loads = np.zeros((weight.shape[0], 0))
    n = loads.shape[1]
    rhs = np.hstack([loads, weight])
    W = rhs.T @ np.asarray(problem.factor().solve(rhs))
    W = 0.5 * (W + W.T)
    return W[:n, :n], W[:n, n:], W[n:, n:]
