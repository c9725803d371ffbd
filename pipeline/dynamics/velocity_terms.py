"""Velocity-dependent inertia terms h(q, q') by the R''|q''=0 route (DESIGN §4).

Lagrange's equations equal sum_g m_g (dR_g/dq_i)^T R''_g, and R''_g =
sum_j dR_g/dq_j q''_j + R''_g|q''=0, so h_i = sum_g m_g (dR_g/dq_i)^T
R''_g|q''=0 with

    R''_g|q''=0 = A''|0 (r_g + eta phi_g) + 2 A' eta' phi_g

(A''|0 from the kinematics; eta'' = 0). With the invariants of one link:

    h_i += tr(dA_i J A''^T) + 2 tr(dA_i Ne A'^T),  Ne = sum_c N_c eta'_c
    h_a += tr(A N_a^T A''^T) + 2 tr(A G_a A'^T),   G_a = sum_c C''_ac eta'_c

and, for a link with second-order mass moments, h_i += dA_i : (A[:, :3] S''^T)
(:func:`pipeline.dynamics.mass_matrix.second_order_acceleration`).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.eye(3))})
>>> q, qd = np.zeros(1), np.ones(1)
>>> float(velocity_terms(s, evaluate_tree(mech, q, qd), q, qd)[0])  # single axis: no h
0.0
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics.mass_matrix import all_link_terms, second_order_acceleration, stacked

__all__ = ["velocity_terms"]


def velocity_terms(system, tree, q: np.ndarray, qd: np.ndarray, links=None) -> np.ndarray:
    """(n,) h(q, q') (N or N m per coordinate unit).

    Parameters
    ----------
    tree : TreeState at (q, qd) with dA, Ad and Add.
    q, qd : (n,) coordinates and rates.
    links : ``all_link_terms(system, q)`` (computed if None).
    """
    n = system.mechanism.n
    links = all_link_terms(system, q) if links is None else links
    if not links:
        return np.zeros(n)
    D, J = stacked(tree, links, n)
    lis = [item[0] for item in links]
    Z = tree.Add[lis] @ J.transpose(0, 2, 1)  # (L, 4, 4)
    h = np.zeros(n)
    for k, (li, body, idx, _, N) in enumerate(links):
        if idx.size:
            A, Ad, Add = tree.A[li], tree.Ad[li], tree.Add[li]
            m = idx.size
            etad = qd[idx]
            Ne = (etad @ N.reshape(m, 16)).reshape(4, 4)
            Z[k] += 2.0 * Ad @ Ne.T
            if body.second_order_moments.size:
                Z[k] += A[:, :3] @ second_order_acceleration(body, etad).T
            G = (etad @ body.Cpp.transpose(1, 0, 2, 3).reshape(m, 16 * m)).reshape(m, 4, 4)
            h[idx] += np.sum(A * (Add @ N + 2.0 * Ad @ G.transpose(0, 2, 1)), axis=(1, 2))
    return h + D @ Z.reshape(-1)
