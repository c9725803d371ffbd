"""Gravity: generalised force Q_i = sum_g m_g G^T dR_g/dq_i and its potential (DESIGN §4).

Only the first-moment columns enter: sum_g m_g (r_g + eta phi_g) = J(eta)[:, 3]
and sum_g m_g phi_a,g = C'_a[3, :] (C'_a^T's fourth column).

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

from pipeline.dynamics.mass_matrix import all_link_terms, stacked

__all__ = ["gravity_force", "gravity_potential"]


def gravity_force(system, tree, q: np.ndarray, links=None) -> np.ndarray:
    """(n,) generalised gravity force at q (tree with dA), N or N m per coordinate unit.

    ``links``: ``all_link_terms(system, q)`` (computed if None).
    """
    g = np.append(system.gravity, 0.0)
    n = system.mechanism.n
    links = all_link_terms(system, q) if links is None else links
    if not links:
        return np.zeros(n)
    D, J = stacked(tree, links, n)
    # (dA J[:, 3]) . g = tr(dA W^T) with W = g J[:, 3]^T
    Q = D @ (g[None, :, None] * J[:, None, :, 3]).reshape(-1)
    for li, body, idx, _, _ in links:
        if idx.size:
            Q[idx] += (body.Cp[:, 3, :] @ tree.A[li].T) @ g
    return Q


def gravity_potential(system, tree, q: np.ndarray) -> float:
    """Gravity potential V = -sum_g m_g G . R_g (J), zero at the ground origin."""
    g = np.append(system.gravity, 0.0)
    V = 0.0
    for li, _, _, J, _ in all_link_terms(system, q):
        V -= float(g @ (tree.A[li] @ J[:, 3]))
    return V
