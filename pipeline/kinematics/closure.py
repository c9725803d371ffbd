"""Loop-closure equations, their analytic Jacobian and the gamma term.

Loop k is closed by its cut joint j between frame a on link P and frame b on
link C: the cut joint's child frame seen from both sides must coincide,

    T_L(q) = A_P S_a(eta_P) Phi_j(q_j)     (parent side through the joint)
    T_R(q) = A_C S_b(eta_C)                (child side)

Six rows per loop, in ground axes:

    position    p_L - p_R                          (3 rows, m)
    orientation vee(R_R R_L^T) = axial vector of skew(R_R R_L^T)   (3 rows, rad)

Why this orientation error: it is a polynomial in the entries of the two
poses (no angles, no log map, no branch cut), so it is smooth everywhere and
its Jacobian follows from the product rule on the 4x4 derivatives dT/dq:
d vee(R_R R_L^T) = vee(dR_R R_L^T + R_R dR_L^T). At closure (R_R R_L^T = 1)
its rate is exactly omega_R - omega_L, the relative angular velocity in
ground axes, so the rows are the standard constraint rows and the rank of
the Jacobian is the true number of constraints. Ground axes give redundant
rows physical names (a loop moving in the x-y plane has zero rows
"position z", "rotation x", "rotation y"). Its only spurious zeros are
relative rotations by 180 deg, far from any user assembly.

gamma: Phi_q q'' = gamma = -(Phi_q q')_q q', obtained from the second time
derivatives of T_L, T_R at q'' = 0 (:mod:`poses`):
p-rows  -(p_L'' - p_R''),  r-rows  -vee(R_R'' R_L^T + 2 R_R' R_L'^T + R_R R_L''^T).

Examples
--------
>>> from pipeline.kinematics.links import rigid_link
>>> from pipeline.kinematics.joints import Joint
>>> from pipeline.kinematics.mechanism import build_mechanism
>>> m = build_mechanism([rigid_link("ground"), rigid_link("a"), rigid_link("b")], [
...     Joint("j1", "revolute", "ground", "body", "a", "body"),
...     Joint("j2", "revolute", "a", "body", "b", "body"),
...     Joint("j3", "fixed", "b", "body", "ground", "body")])
>>> r, J = closure_jacobian(m, np.array([0.1, -0.1]))
>>> float(np.abs(r).max()) < 1e-15, J.shape
(True, (6, 2))
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.kinematics.mechanism import Mechanism
from pipeline.kinematics.poses import TreeState, evaluate_tree, step_pose, step_value
from pipeline.kinematics.rotations import vee

__all__ = ["ClosureValue", "closure", "closure_gamma", "closure_jacobian",
           "closure_residual", "row_weights"]


@dataclass(frozen=True)
class ClosureValue:
    """Closure quantities at one configuration (rows: 6 per loop).

    Attributes
    ----------
    r : (6 k,) residual (m, rad).
    J : (6 k, n) dr/dq, or None.
    gamma : (6 k,) right-hand side of J q'' = gamma, or None.
    tree : the link poses (and derivatives) used.
    """

    r: np.ndarray
    J: np.ndarray | None
    gamma: np.ndarray | None
    tree: TreeState


def row_weights(mech: Mechanism) -> np.ndarray:
    """(6 k,) weights making rows dimensionless: 1/length_scale on positions, 1 on rotations."""
    w = np.ones(6 * len(mech.topology.loops))
    w.reshape(-1, 6)[:, :3] = 1.0 / mech.length_scale
    return w


def closure(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
            jacobian: bool = True, tree: TreeState | None = None) -> ClosureValue:
    """Residual, Jacobian (if ``jacobian``) and gamma (if ``qd``) at q (n,).

    ``tree`` may pass in link poses already evaluated at the same q (and qd)
    with matching derivative content.
    """
    q = np.asarray(q, dtype=float)
    if tree is None:
        tree = evaluate_tree(mech, q, qd, derivatives=jacobian)
    loops = mech.loop_steps
    r = np.empty(6 * len(loops))
    J = np.empty((6 * len(loops), mech.n)) if jacobian else None
    g = np.empty(6 * len(loops)) if qd is not None else None
    for k, (left, right) in enumerate(loops):
        a = step_value(left, tree.A, tree.dA, tree.Ad, tree.Add, q, qd, jacobian)
        b = step_value(right, tree.A, tree.dA, tree.Ad, tree.Add, q, qd, jacobian)
        RL, RR = a.P[:3, :3], b.P[:3, :3]
        s = slice(6 * k, 6 * k + 6)
        r[s][:3] = a.P[:3, 3] - b.P[:3, 3]
        r[s][3:] = vee(RR @ RL.T)
        if jacobian:
            J[s][:3] = (a.dP[:, :3, 3] - b.dP[:, :3, 3]).T
            dE = b.dP[:, :3, :3] @ RL.T + RR @ a.dP[:, :3, :3].transpose(0, 2, 1)
            J[s][3:] = vee(dE).T
        if qd is not None:
            g[s][:3] = b.Pdd[:3, 3] - a.Pdd[:3, 3]
            E2 = b.Pdd[:3, :3] @ RL.T + 2.0 * b.Pd[:3, :3] @ a.Pd[:3, :3].T \
                + RR @ a.Pdd[:3, :3].T
            g[s][3:] = -vee(E2)
    return ClosureValue(r, J, g, tree)


def closure_residual(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """(6 k,) closure residual at q (n,): position (m) and orientation (rad) rows per loop."""
    q = np.asarray(q, dtype=float)
    A = evaluate_tree(mech, q, derivatives=False).A
    r = np.empty(6 * len(mech.loop_steps))
    for k, (left, right) in enumerate(mech.loop_steps):
        TL, TR = step_pose(left, A, q), step_pose(right, A, q)
        r[6 * k:6 * k + 3] = TL[:3, 3] - TR[:3, 3]
        r[6 * k + 3:6 * k + 6] = vee(TR[:3, :3] @ TL[:3, :3].T)
    return r


def closure_jacobian(mech: Mechanism, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residual (6 k,) and analytic Jacobian (6 k, n) at q."""
    c = closure(mech, q)
    return c.r, c.J


def closure_gamma(mech: Mechanism, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """(6 k,) gamma = -(J q')_q q' at (q, q')."""
    return closure(mech, q, np.asarray(qd, dtype=float), jacobian=False).gamma
