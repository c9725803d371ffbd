"""Lagrange's equations in all tree coordinates: M(q) q'' = rhs(q, q', t) (DESIGN §4).

rhs = Q_gravity + Q_elastic + Q_damping + Q_forces - h, with
Q_elastic = -K eta and Q_damping = -D eta' per flexible body and Q_forces the
virtual work of the system's force elements (their compiled form,
``System.compiled_forces``). Closed loops are reduced by :mod:`pipeline.dynamics.partition`.

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(1.0, [1.0, 0, 0], np.zeros((3, 3)))},
...            gravity=[0.0, -9.81, 0.0])
>>> M, rhs = equations(s, np.zeros(1), np.zeros(1), 0.0)
>>> round(float(rhs[0] / M[0, 0]), 12)  # point pendulum, horizontal: -g / l
-9.81
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.dynamics.compiled import inertia_terms
from pipeline.kinematics.poses import TreeState, evaluate_tree

__all__ = ["EquationTerms", "elastic_forces", "equation_terms", "equations", "state_rates"]


@dataclass(frozen=True)
class EquationTerms:
    """Every term of M q'' + h = Q at one state (all (n,) except M (n, n)).

    ``Q_nonconservative`` is the part whose power is dissipated or supplied
    (modal damping plus the non-conservative force elements).
    """

    M: np.ndarray
    h: np.ndarray
    Q_gravity: np.ndarray
    Q_elastic: np.ndarray
    Q_damping: np.ndarray
    Q_forces: np.ndarray
    Q_nonconservative: np.ndarray
    tree: TreeState

    @property
    def rhs(self) -> np.ndarray:
        return self.Q_gravity + self.Q_elastic + self.Q_damping + self.Q_forces - self.h


def elastic_forces(system, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Q_elastic, Q_damping), each (n,): -K eta and -D eta' of every flexible body."""
    K, D = system.modal_stiffness_damping
    return -(K @ q), -(D @ qd)


def equation_terms(system, q: np.ndarray, qd: np.ndarray, t: float,
                   tree: TreeState | None = None, inertia: tuple | None = None,
                   z: np.ndarray | None = None) -> EquationTerms:
    """All terms of the equations of motion at (q, qd, t).

    Parameters
    ----------
    q, qd : (n,) coordinates and rates.
    t : time, s.
    tree : TreeState at (q, qd) with dA, Ad, Add (computed if None).
    inertia : (M, h, Q_gravity) at this state if the caller has them.
    z : (nz,) the force elements' own states (System.state_slices), for a system with
        such elements; without them those elements raise ConfigError.
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    if tree is None:
        tree = evaluate_tree(system.mechanism, q, qd, derivatives=True)
    if inertia is not None:
        M, h, Qg = inertia
    else:  # M, h and gravity in one compiled pass (pipeline.dynamics.compiled)
        M, h, Qg = inertia_terms(system.compiled_masses, tree, q, qd, system.gravity4)
    Qe, Qd = elastic_forces(system, q, qd)
    # every force element and its non-conservative part (not -dV/dq), compiled
    Qf, Qnc = system.compiled_forces.forces(tree, q, qd, t, z)
    return EquationTerms(M, h, Qg, Qe, Qd, Qf, Qd + Qnc, tree)


def state_rates(system, q: np.ndarray, qd: np.ndarray, t: float, z: np.ndarray,
                tree: TreeState | None = None) -> np.ndarray:
    """(nz,) the rates z' of the force elements' own states at (q, qd, t, z)."""
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    if tree is None:
        tree = evaluate_tree(system.mechanism, q, qd, derivatives=True)
    return system.compiled_forces.rates(tree, q, qd, t, z)


def equations(system, q: np.ndarray, qd: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """M (n, n) and rhs = Q_gravity + Q_elastic + Q_damping + Q_forces - h (n,) at (q, qd, t)."""
    terms = equation_terms(system, q, qd, t)
    return terms.M, terms.rhs
