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
from pipeline.kinematics.poses import (
    Locals,
    TreeState,
    _compiled_evaluate,
    evaluate_tree,
    local_matrices,
    local_rates,
    place_d,
    place_rates,
    tree_with_rates,
)

_I = ([2, 0, 1], [1, 2, 0])  # vee(E) = (E[I] - E[I^T]) / 2
_IT = ([1, 2, 0], [2, 0, 1])

__all__ = ["ClosureValue", "closure", "closure_gamma", "closure_jacobian",
           "closure_rates", "closure_residual", "row_weights"]


@dataclass(frozen=True)
class ClosureValue:
    """Closure quantities at one configuration (rows: 6 per loop).

    Attributes
    ----------
    r : (6 k,) residual (m, rad).
    J : (6 k, n) dr/dq, or None.
    gamma : (6 k,) right-hand side of J q'' = gamma, or None.
    tree : the link poses (and derivatives) used.
    local : the steps' local matrices at q (and q' when gamma is set).
    """

    r: np.ndarray
    J: np.ndarray | None
    gamma: np.ndarray | None
    tree: TreeState
    local: Locals | None = None


def row_weights(mech: Mechanism) -> np.ndarray:
    """(6 k,) weights making rows dimensionless: 1/length_scale on positions, 1 on rotations."""
    return np.array(mech.row_weights)


def closure(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
            jacobian: bool = True, compiled: bool = True) -> ClosureValue:
    """Residual, Jacobian (if ``jacobian``) and gamma (if ``qd``) at q (n,).

    ``compiled``: use the compiled pass of :mod:`pipeline.kinematics.compiled` (same
    values to rounding); False runs the numpy reference implementation.
    """
    q = np.asarray(q, dtype=float)
    if compiled and _compiled_evaluate is not None:
        ev = _compiled_evaluate(mech.compiled, q, qd)
        tree = TreeState(ev.A, ev.dA, ev.Ad, ev.Add)
        return ClosureValue(ev.r, ev.J if jacobian else None, ev.gamma, tree)
    loc = local_matrices(mech, q, qd, jacobian)
    tree = evaluate_tree(mech, q, qd, jacobian, loc)
    K, n = len(mech.loop_steps), mech.n
    if K == 0:
        return ClosureValue(np.zeros(0), np.zeros((0, n)) if jacobian else None,
                            None if qd is None else np.zeros(0), tree, loc)
    slots = [k for pair in mech.table.loop_slot for k in pair]
    J = g = None
    if jacobian:
        Zs = np.array([place_d(k, loc, mech, tree.Z) for k in slots]).reshape(K, 2, 1 + n, 4, 4)
        P, dP = Zs[:, :, 0], Zs[:, :, 1:]
    else:
        P = np.array([tree.A[mech.table.steps[k].frm] @ loc.M[k] for k in slots]).reshape(
            K, 2, 4, 4)
    RL, RR = P[:, 0, :3, :3], P[:, 1, :3, :3]
    RLt = RL.transpose(0, 2, 1)
    r = np.empty((K, 6))
    r[:, :3] = P[:, 0, :3, 3] - P[:, 1, :3, 3]
    r[:, 3:] = _vee(RR @ RLt)
    if jacobian:
        J = np.empty((K, 6, n))
        J[:, :3] = (dP[:, 0, :, :3, 3] - dP[:, 1, :, :3, 3]).transpose(0, 2, 1)
        dE = dP[:, 1, :, :3, :3] @ RLt[:, None] + RR[:, None] @ dP[:, 0, :, :3, :3].transpose(
            0, 1, 3, 2)
        J[:, 3:] = _vee(dE).transpose(0, 2, 1)
        J = J.reshape(6 * K, n)
    if qd is not None:
        g = _gamma(mech, loc, tree)
    return ClosureValue(r.reshape(-1), J, g, tree, loc)


def _gamma(mech: Mechanism, loc: Locals, tree: TreeState) -> np.ndarray:
    """(6 k,) gamma from local matrices and a tree with rates."""
    K = len(mech.loop_steps)
    slots = [k for pair in mech.table.loop_slot for k in pair]
    Ys = np.array([place_rates(k, loc, mech, tree.Y) for k in slots]).reshape(K, 2, 4, 12)
    P, Pd, Pdd = Ys[..., :4], Ys[..., 4:8], Ys[..., 8:]
    RLt = P[:, 0, :3, :3].transpose(0, 2, 1)
    g = np.empty((K, 6))
    g[:, :3] = Pdd[:, 1, :3, 3] - Pdd[:, 0, :3, 3]
    E2 = Pdd[:, 1, :3, :3] @ RLt + 2.0 * Pd[:, 1, :3, :3] @ Pd[:, 0, :3, :3].transpose(
        0, 2, 1) + P[:, 1, :3, :3] @ Pdd[:, 0, :3, :3].transpose(0, 2, 1)
    g[:, 3:] = -_vee(E2)
    return g.reshape(-1)


def closure_rates(mech: Mechanism, c: ClosureValue, q: np.ndarray,
                  qd: np.ndarray) -> ClosureValue:
    """``c`` (evaluated at q with the Jacobian, no rates) completed with gamma and the tree's
    A', A'' at the rates qd (n,): the numpy path does not evaluate the positions again
    (the compiled pass, which holds no local matrices, evaluates everything at once)."""
    if c.local is None:
        return closure(mech, q, qd)
    loc = local_rates(mech, q, np.asarray(qd, dtype=float), c.local)
    tree = tree_with_rates(mech, c.tree, loc)
    g = _gamma(mech, loc, tree) if mech.loop_steps else np.zeros(0)
    return ClosureValue(c.r, c.J, g, tree, loc)


def _vee(E: np.ndarray) -> np.ndarray:
    """(..., 3) axial vector of the skew part of E (..., 3, 3)."""
    return 0.5 * (E[..., _I[0], _I[1]] - E[..., _IT[0], _IT[1]])


def closure_residual(mech: Mechanism, q: np.ndarray) -> np.ndarray:
    """(6 k,) closure residual at q (n,): position (m) and orientation (rad) rows per loop."""
    return closure(mech, q, jacobian=False).r


def closure_jacobian(mech: Mechanism, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residual (6 k,) and analytic Jacobian (6 k, n) at q."""
    c = closure(mech, q)
    return c.r, c.J


def closure_gamma(mech: Mechanism, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """(6 k,) gamma = -(J q')_q q' at (q, q')."""
    return closure(mech, q, np.asarray(qd, dtype=float), jacobian=False).gamma
