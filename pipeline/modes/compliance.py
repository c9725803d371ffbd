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
    R = np.asarray(axes, dtype=float)
    to_body = sp.block_diag([R.T, R.T] * len(frames), format="csr")
    G = to_body @ sp.vstack([interface_operator(model, f) for f in frames], format="csr")
    expand = tied.transform @ problem.space.L  # clamped coordinates -> full DOFs
    loads = np.asarray((expand.T @ G.T).todense())  # (n_c, 6F): G^T e of every direction
    U = np.asarray(problem.factor().solve(loads))
    C = loads.T @ U
    return 0.5 * (C + C.T)
