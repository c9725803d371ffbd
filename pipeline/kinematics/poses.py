"""Link poses A_l(q), their derivatives and acceleration terms on 4x4 matrices.

Forward recursion over the compiled tree (:mod:`mechanism`): with
A_to = A_frm M(q), M = S(eta_frm) Phi(q_j) tail,

    dA_to/dq_i = dA_frm/dq_i M + A_frm dM/dq_i,
    A_to'  = A_frm' M + A_frm M',
    A_to'' = A_frm'' M + 2 A_frm' M' + A_frm M''     (q'' = 0 part),

where S is linear in eta (dS/deta constant, S'' = 0 at eta'' = 0) -- or, for a
frame with second-order translation, S = S_0 + eta_a dS_a + eta_a eta_b H_ab / 2 in its
origin column (then dS/deta_a = dS_a + H_ab eta_b and S'' = eta'_a eta'_b H_ab) -- and the
joint supplies Phi, dPhi/dq, Phi' and Phi''|q''=0. The full acceleration is
A'' = sum_i dA/dq_i q''_i + A''|q''=0, the form the dynamics layer needs
(R''_g|q''=0 of DESIGN §4).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics.links import rigid_link
>>> from pipeline.kinematics.joints import Joint
>>> from pipeline.kinematics.mechanism import build_mechanism
>>> from pipeline.kinematics.rotations import translation
>>> m = build_mechanism([rigid_link("ground"), rigid_link("arm", {"tip": translation([1, 0, 0])})],
...                     [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> st = evaluate_tree(m, np.array([np.pi / 2]))
>>> P = step_pose(m.marker("arm", "tip"), st.A, np.array([np.pi / 2]))
>>> np.round(P[:3, 3], 12).tolist()
[0.0, 1.0, 0.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.kinematics.mechanism import Mechanism, Step

__all__ = ["StepValue", "TreeState", "evaluate_tree", "step_local", "step_pose", "step_value"]

_I4 = np.eye(4)
_Z4 = np.zeros((4, 4))
_NO_D = np.zeros((0, 4, 4))
for _a in (_I4, _Z4, _NO_D):
    _a.setflags(write=False)


@dataclass(frozen=True)
class TreeState:
    """Poses of every link (index order of ``Mechanism.links``).

    Attributes
    ----------
    A : (L, 4, 4) body-frame poses in ground.
    dA : (L, n, 4, 4) dA_l/dq_i, or None.
    Ad : (L, 4, 4) dA_l/dt, or None (no qd given).
    Add : (L, 4, 4) d2A_l/dt2 at q'' = 0, or None.
    """

    A: np.ndarray
    dA: np.ndarray | None
    Ad: np.ndarray | None
    Add: np.ndarray | None


@dataclass(frozen=True)
class StepValue:
    """Global pose P = A_frm M of a step's end and its derivatives (as TreeState, one frame)."""

    P: np.ndarray
    dP: np.ndarray | None
    Pd: np.ndarray | None
    Pdd: np.ndarray | None


def _fast_local(fast, q, qd, need_d):
    """Closed-form M, dM, M', M'' of a rigid one-motion step (see ``Step.fast``)."""
    kind, C0, C1, C2, i = fast
    if kind == "fixed":
        return C0, _NO_D, (None if qd is None else _Z4), (None if qd is None else _Z4)
    x = q[i]
    if kind == "T":
        M, dM0, Mdd = C0 + x * C1, C1, _Z4
    else:
        c, s = math.cos(x), math.sin(x)
        M = C0 + s * C1 + (1.0 - c) * C2
        dM0 = c * C1 + s * C2
        Mdd = None if qd is None else (qd[i] * qd[i]) * (c * C2 - s * C1)
    return M, (dM0[None] if need_d else None), (None if qd is None else qd[i] * dM0), Mdd


def step_local(step: Step, q: np.ndarray, qd: np.ndarray | None = None, need_d: bool = True):
    """Local matrix M (4, 4), dM/dq_local (k, 4, 4), M' and M''|q''=0 of a step."""
    if step.fast is not None:
        return _fast_local(step.fast, q, qd, need_d)
    fr = step.frame
    eta = q[step.eta_idx] if fr.n_modes else None
    S = fr.shape(eta) if fr.n_modes else fr.pose
    dS = fr.shape_derivatives(eta) if fr.n_modes else None
    tail = step.tail
    if step.motion is not None:
        G, dG, Gd, Gdd = step.motion.evaluate(q[step.q_idx], None if qd is None else qd[step.q_idx])
    else:
        G, dG, Gd, Gdd = _I4, None, _Z4, _Z4
    SG = S @ G
    M = SG if tail is None else SG @ tail
    dM = Md = Mdd = None
    if need_d:
        parts = []
        if fr.n_modes:
            parts.append(dS @ G)
        if dG is not None:
            parts.append(S @ dG)
        dM = np.concatenate(parts) if len(parts) > 1 else parts[0] if parts else np.zeros((0, 4, 4))
        if tail is not None:
            dM = dM @ tail
    if qd is not None:
        if fr.n_modes:
            Sd = (qd[step.eta_idx] @ dS.reshape(fr.n_modes, 16)).reshape(4, 4)
            Md = Sd @ G + S @ Gd
            Mdd = 2.0 * Sd @ Gd + S @ Gdd
            Sdd = fr.shape_acceleration(qd[step.eta_idx])
            if Sdd is not None:  # a second-order frame: S'' = eta'^T H eta'
                Mdd = Mdd + Sdd @ G
        else:
            Md, Mdd = S @ Gd, S @ Gdd
        if tail is not None:
            Md, Mdd = Md @ tail, Mdd @ tail
    return M, dM, Md, Mdd


def step_value(step: Step, A, dA, Ad, Add, q, qd=None, need_d=True) -> StepValue:
    """Pose of a step's end from the state of its base link (all (L, ...) arrays)."""
    f = step.frm
    M, dM, Md, Mdd = step_local(step, q, qd, need_d)
    Af = A[f]
    P = Af @ M
    dP = None
    if need_d:
        dP = dA[f] @ M
        if step.fast is not None and step.fast[4] >= 0:  # one local coordinate
            dP[step.fast[4]] += Af @ dM[0]
        elif len(step.local):
            dP[step.local] += Af @ dM
    Pd = Pdd = None
    if qd is not None:
        Pd = Ad[f] @ M + Af @ Md
        Pdd = Add[f] @ M + 2.0 * Ad[f] @ Md + Af @ Mdd
    return StepValue(P, dP, Pd, Pdd)


def step_pose(step: Step, A: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(4, 4) global pose of a step's end given the link poses A (L, 4, 4)."""
    return A[step.frm] @ step_local(step, q, None, need_d=False)[0]


def evaluate_tree(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
                  derivatives: bool = True) -> TreeState:
    """Poses of every link at q (n,); with ``derivatives`` also dA/dq; with qd also A', A''.

    One compiled pass (:mod:`pipeline.kinematics.compiled`); the numpy form of the same
    recursion is the tests' oracle (``tests/kinematics/poses_numpy.py``).

    Parameters
    ----------
    q : (n,) coordinates (rad, m, modal).
    qd : (n,) coordinate rates, optional.
    derivatives : return dA/dq (L, n, 4, 4) too.
    """
    from pipeline.kinematics.compiled import evaluate

    ev = evaluate(mech.compiled, np.asarray(q, dtype=float), qd)
    return TreeState(ev.A, ev.dA if derivatives else None, ev.Ad, ev.Add)
