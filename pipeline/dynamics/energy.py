"""Energies of a state: kinetic, gravity, elastic strain and force-element potentials.

T = 1/2 q'^T M(q) q' (the mass matrix of :mod:`mass_matrix`; link by link it is
T_l = 1/2 tr(A' J A'^T) + tr(A' Ne A^T) + 1/2 sum_ab eta'_a eta'_b tr(A C''_ab A^T)
with Ne = sum_a N_a eta'_a, DESIGN §4, the form the tests check it against);
V_elastic = 1/2 eta^T K eta. The energy dissipated (or supplied) by non-conservative terms
is integrated by the solver.

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.diag([0, 0, 0.5]))})
>>> q, qd = np.zeros(1), np.array([2.0])
>>> round(kinetic_energy(s, evaluate_tree(mech, q, qd), q, qd), 12)
5.0
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics.gravity import gravity_potential
from pipeline.dynamics.mass_matrix import mass_matrix

__all__ = ["elastic_energy", "energies", "kinetic_energy"]


def kinetic_energy(system, tree, q: np.ndarray, qd: np.ndarray) -> float:
    """T = 1/2 q'^T M(q) q' (J) at (q, qd); ``tree`` at q (its dA computed if absent)."""
    if tree.dA is None:
        from pipeline.kinematics.poses import evaluate_tree

        tree = evaluate_tree(system.mechanism, q)
    qd = np.asarray(qd, dtype=float)
    return 0.5 * float(qd @ mass_matrix(system, tree, q) @ qd)


def elastic_energy(system, q: np.ndarray) -> float:
    """Modal strain energy 1/2 eta^T K eta summed over the flexible bodies, J."""
    V = 0.0
    for _, body, idx in system.mass_links:
        if idx.size:
            V += 0.5 * float(q[idx] @ body.stiffness @ q[idx])
    return V


def energies(system, tree, q: np.ndarray, qd: np.ndarray,
             M: np.ndarray | None = None) -> dict[str, float]:
    """{'kinetic', 'gravity', 'elastic', 'forces'} energies (J) at (q, qd).

    ``forces`` sums the potential energy of the force elements (springs). ``M``: the
    mass matrix at q (n, n) if the caller has it (else computed: :func:`kinetic_energy`).
    """
    Vf = system.compiled_forces.potential(tree, q)
    T = kinetic_energy(system, tree, q, qd) if M is None else 0.5 * float(qd @ M @ qd)
    return {"kinetic": T,
            "gravity": gravity_potential(system, tree, q),
            "elastic": elastic_energy(system, q),
            "forces": Vf}
