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

from dataclasses import dataclass

import numpy as np

from pipeline.kinematics.mechanism import Mechanism, Step

__all__ = ["StepValue", "TreeState", "evaluate_tree", "step_pose", "step_value"]


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


def step_value(step: Step, A, dA, Ad, Add, q, qd=None, need_d=True) -> StepValue:
    """Pose of a step's end from the state of its base link (all (L, ...) arrays): with
    ``need_d`` dP/dq (from dA), with qd P' and P''|q''=0 (from Ad, Add). Compiled
    (:func:`pipeline.kinematics.compiled.step_values`, the tree's own step evaluation)."""
    from pipeline.kinematics.compiled import step_values

    v = step_values(step.compiled, q, A, dA if need_d else None, Ad, Add, qd)
    return StepValue(v.P[0], None if v.dP is None else v.dP[0],
                     None if v.Pd is None else v.Pd[0], None if v.Pdd is None else v.Pdd[0])


def step_pose(step: Step, A: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(4, 4) global pose of a step's end given the link poses A (L, 4, 4)."""
    return step_value(step, A, None, None, None, q, None, need_d=False).P


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
