"""Mass matrix of the rigid/flexible tree by traces of 4x4 products (DESIGN §4).

A point g of link l is R_g = A_l (r_g + sum_a eta_a phi_a,g) (homogeneous,
phi with a zero fourth entry). Its Jacobian column for coordinate i is
dR_g/dq_i = dA_l/dq_i (r_g + eta phi_g) + A_l phi_a,g [i = eta_a of link l].
Summed over the mass points with the invariants C, C'_a, C''_ab:

    M_ij  += tr(dA_i J(eta) dA_j^T)                     (every i, j)
    M_ia  += tr(dA_i N_a A^T),  N_a = C'_a + sum_b eta_b C''_ba
    M_ab  += tr(A C''_ab A^T)

with J(eta) = C + sum eta_a (C'_a + C'_a^T) + sum eta_a eta_b C''_ab. dA
carries the dependence of A_l on the modal coordinates of every upstream
link (the terms the thesis drops), so M is exact for the kinematics' A_l.

A link with geometric stiffening also carries the second-order part of its mass
moments, int rho xb u2^T dV = sum_ab eta_a eta_b G_ab / 2 (``second_order_moments``,
xb = [x, y, z, 1] in body axes, u2 the second-order displacement): its mass moves
towards the reference as it bends. Its moments up to the first in the body coordinates
couple to the motion of the body frame; the rest (with the modes, O(eta) in the modal
mass) is left out. With S(eta) = sum_ab eta_a eta_b G_ab / 2 (4, 3) it adds

    J[:, :3] += S,  J[:3, :] += S^T,   N_a[:, :3] += sum_b G_ab eta_b

and the velocity terms gain A xb u2''|eta''=0, i.e. Z += A[:, :3] S''^T with
S'' = sum_ab eta'_a eta'_b G_ab. These are Lagrange's equations of the kinetic energy
with the cross term int rho (T' xb) . d(T u2)/dt of the rigid motion with the moving mass,
and gravity gains -g . A u2's mean. An inertia field of the body frame -- the
acceleration a of its origin, its spin, its angular acceleration, gravity -- then
stiffens the modes by the geometric stiffness of that field (``G_ab[j, k] = -K_jk``, the
unit inertia cases of :mod:`pipeline.invariants.stiffening`), with the energy to match.

The sums are computed once, compiled, over subtrees (:mod:`pipeline.dynamics.compiled`);
their link-by-link numpy form is the tests' oracle (``tests/dynamics/inertia_numpy.py``).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.diag([0, 0, 0.5]))})
>>> q = np.zeros(1)
>>> round(float(mass_matrix(s, evaluate_tree(mech, q), q)[0, 0]), 12)  # I_c + m d^2
2.5
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics.compiled import inertia_terms, link_terms, second_order_acceleration

__all__ = ["link_terms", "mass_matrix", "second_order_acceleration"]


def mass_matrix(system, tree, q: np.ndarray) -> np.ndarray:
    """(n, n) generalised mass matrix at q, symmetric, kg / kg m / kg m^2 per coordinate
    units.

    Parameters
    ----------
    system : System.
    tree : TreeState at q with dA (``evaluate_tree(..., derivatives=True)``).
    q : (n,) coordinates (rad, m, modal).
    """
    return inertia_terms(system.compiled_masses, tree, q, None, system.gravity4)[0]
