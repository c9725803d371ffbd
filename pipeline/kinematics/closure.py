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
from pipeline.kinematics.poses import TreeState

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
    """

    r: np.ndarray
    J: np.ndarray | None
    gamma: np.ndarray | None
    tree: TreeState


def row_weights(mech: Mechanism) -> np.ndarray:
    """(6 k,) weights making rows dimensionless: 1/length_scale on positions, 1 on rotations."""
    return np.array(mech.row_weights)


def closure(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
            jacobian: bool = True) -> ClosureValue:
    """Residual, Jacobian (if ``jacobian``) and gamma (if ``qd``) at q (n,): one compiled
    pass (:mod:`pipeline.kinematics.compiled`; the numpy form of the same rows is the tests'
    oracle, ``tests/kinematics/poses_numpy.py``)."""
    from pipeline.kinematics.compiled import evaluate

    ev = evaluate(mech.compiled, np.asarray(q, dtype=float), qd)
    tree = TreeState(ev.A, ev.dA, ev.Ad, ev.Add)
    return ClosureValue(ev.r, ev.J if jacobian else None, ev.gamma, tree)


def closure_rates(mech: Mechanism, c: ClosureValue, q: np.ndarray,
                  qd: np.ndarray) -> ClosureValue:
    """``c`` (evaluated at q with the Jacobian, no rates) completed with gamma and the tree's
    A', A'' at the rates qd (n,) (the compiled pass evaluates everything at once)."""
    return closure(mech, q, np.asarray(qd, dtype=float), jacobian=c.J is not None)


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
