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

from pipeline.dynamics.mass_matrix import all_link_terms, stacked

__all__ = ["first_moments", "gravity_force", "gravity_potential"]


def gravity_force(system, tree, q: np.ndarray, links=None) -> np.ndarray:
    """(n,) generalised gravity force at q (tree with dA), N or N m per coordinate unit.

    ``links``: ``all_link_terms(system, q)`` (computed if None).
    """
    g = system.gravity4
    n = system.mechanism.n
    links = all_link_terms(system, q) if links is None else links
    if not links:
        return np.zeros(n)
    D, J = stacked(tree, links, n)
    # (dA J[:, 3]) . g = tr(dA W^T) with W = g J[:, 3]^T
    Q = D @ (g[None, :, None] * J[:, None, :, 3]).reshape(-1)
    for li, _, idx, _, N in links:
        if idx.size:
            Q[idx] += (N[:, 3, :] @ tree.A[li].T) @ g
    return Q


def gravity_potential(system, tree, q: np.ndarray) -> float:
    """Gravity potential V = -sum_g m_g G . R_g (J), zero at the ground origin.

    Only the first moments J(eta)[:, 3] = sum_g m_g (r_g + eta phi_g) of the links enter,
    stacked over the links (:func:`first_moments`)."""
    links, J3 = first_moments(system, q)
    if not links.size:
        return 0.0
    return -float(np.einsum("bij,bj,i->", tree.A[links], J3, system.gravity4))


def first_moments(system, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Link indices (B,) of the massive links and their first moments J(eta)[:, 3] (B, 4)
    (kg m, kg) at q (n,): C[:, 3] + sum_a eta_a (C'_a[:, 3] + C'_a[3, :])
    + sum_ab eta_a eta_b C''_ab[:, 3] (+ the second-order part, P2 holding it), the fourth
    column of :func:`link_terms`' J."""
    li, C3, flexible = system.first_moment_data
    J3 = C3.copy()
    for b, idx, P1, P2 in flexible:
        eta = q[idx]
        J3[b] += eta @ P1 + eta @ (P2 @ eta)
    return li, J3
