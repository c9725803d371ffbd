"""Energies of a state: kinetic, gravity, elastic strain and force-element potentials.

T_l = 1/2 tr(A' J A'^T) + tr(A' Ne A^T) + 1/2 sum_ab eta'_a eta'_b tr(A C''_ab A^T)
with Ne = sum_a N_a eta'_a (DESIGN §4); V_elastic = 1/2 eta^T K eta. The energy
dissipated (or supplied) by non-conservative terms is integrated by the solver.

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.diag([0, 0, 0.5]))})
>>> q, qd = np.zeros(1), np.array([2.0])
>>> round(kinetic_energy(s, evaluate_tree(mech, q, qd, derivatives=False), q, qd), 12)
5.0
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics.gravity import gravity_potential
from pipeline.dynamics.mass_matrix import link_terms, mass_links, modal_block

__all__ = ["elastic_energy", "energies", "kinetic_energy"]


def kinetic_energy(system, tree, q: np.ndarray, qd: np.ndarray) -> float:
    """T (J) at (q, qd); ``tree`` needs A and Ad."""
    T = 0.0
    for li, body, idx in mass_links(system):
        A, Ad = tree.A[li], tree.Ad[li]
        J, N = link_terms(body, q[idx])
        T += 0.5 * float(np.sum((Ad @ J) * Ad))
        if idx.size:
            etad = qd[idx]
            Ne = (etad @ N.reshape(idx.size, 16)).reshape(4, 4)
            T += float(np.sum((Ad @ Ne) * A))
            Mee = modal_block(A, body.Cpp)
            T += 0.5 * float(etad @ Mee @ etad)
    return T


def elastic_energy(system, q: np.ndarray) -> float:
    """Modal strain energy 1/2 eta^T K eta summed over the flexible bodies, J."""
    V = 0.0
    for _, body, idx in mass_links(system):
        if idx.size:
            V += 0.5 * float(q[idx] @ body.stiffness @ q[idx])
    return V


def energies(system, tree, q: np.ndarray, qd: np.ndarray,
             M: np.ndarray | None = None) -> dict[str, float]:
    """{'kinetic', 'gravity', 'elastic', 'forces'} energies (J) at (q, qd).

    ``forces`` sums the potential energy of the force elements (springs). ``M``: the
    mass matrix at q (n, n) if the caller has it; T = 1/2 q'^T M q' then (T is
    quadratic in q'), otherwise T comes from the link poses (:func:`kinetic_energy`).
    """
    Vf = sum(float(f.potential_energy(system, tree, q)) for f in system.forces)
    T = kinetic_energy(system, tree, q, qd) if M is None else 0.5 * float(qd @ M @ qd)
    return {"kinetic": T,
            "gravity": gravity_potential(system, tree, q),
            "elastic": elastic_energy(system, q),
            "forces": Vf}
