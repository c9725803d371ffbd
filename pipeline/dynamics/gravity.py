"""Gravity: generalised force Q_i = sum_g m_g G^T dR_g/dq_i and its potential (DESIGN §4).

Only the first-moment columns enter: sum_g m_g (r_g + eta phi_g) = J(eta)[:, 3]
and its derivatives sum_g m_g phi_a,g = N_a(eta)[3, :] (C'_a[3, :] for linear modes; plus
G_ab[3] eta_b with second-order mass moments, :func:`pipeline.dynamics.mass_matrix.link_terms`).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.eye(3))},
...            gravity=[0.0, -10.0, 0.0])
>>> q = np.zeros(1)
>>> float(gravity_force(s, evaluate_tree(mech, q), q)[0])  # -m g d
-20.0
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics.compiled import gravity_potential as _potential
from pipeline.dynamics.compiled import inertia_terms

__all__ = ["gravity_force", "gravity_potential"]


def gravity_force(system, tree, q: np.ndarray) -> np.ndarray:
    """(n,) generalised gravity force at q (tree with dA), N or N m per coordinate unit."""
    return inertia_terms(system.compiled_masses, tree, q, None, system.gravity4)[2]


def gravity_potential(system, tree, q: np.ndarray) -> float:
    """Gravity potential V = -sum_g m_g G . R_g (J), zero at the ground origin: only the
    links' first moments J(eta)[:, 3] = sum_g m_g (r_g + eta phi_g) enter."""
    return float(_potential(np.ascontiguousarray(q, dtype=float),
                            np.ascontiguousarray(tree.A), system.gravity4,
                            system.compiled_masses.arrays()))
