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

__all__ = ["all_link_terms", "link_terms", "mass_links", "mass_matrix", "modal_block",
           "second_order_acceleration", "stacked"]


def mass_links(system) -> tuple[tuple[int, object, np.ndarray], ...]:
    """(link index, BodyMass, modal indices in q) of every link that has mass."""
    return system.mass_links


def link_terms(body, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """J(eta) (4, 4) and N_a = C'_a + sum_b eta_b C''_ba (m, 4, 4) of one body.

    Parameters
    ----------
    body : BodyMass with m modes.
    eta : (m,) modal coordinates of the body.
    """
    m = body.n_modes
    if m == 0:
        return body.C, np.zeros((0, 4, 4))
    Cp = body.Cp
    dN = (eta @ body.Cpp.reshape(m, 16 * m)).reshape(m, 4, 4)  # sum_b eta_b C''_ba
    Ce = (eta @ Cp.reshape(m, 16)).reshape(4, 4)
    # J = C + sum_a eta_a (C'_a + C'_a^T) + sum_ab eta_a eta_b C''_ab
    J = body.C + Ce + Ce.T + (eta @ dN.reshape(m, 16)).reshape(4, 4)
    N = Cp + dN
    G = body.second_order_moments
    if G.size:  # the second-order mass moments S = sum eta_a eta_b G_ab / 2 (module doc)
        dS = np.einsum("abjk,b->ajk", G, eta)
        S = 0.5 * np.einsum("a,ajk->jk", eta, dS)
        J[:, :3] += S
        J[:3, :] += S.T
        N[:, :, :3] += dS
    return J, N


def second_order_acceleration(body, etad: np.ndarray) -> np.ndarray:
    """(4, 3) S''|eta''=0 = sum_ab eta'_a eta'_b G_ab, int rho xb u2''^T dV at zero modal
    acceleration (body axes), zeros without second-order moments (:func:`link_terms`)."""
    G = body.second_order_moments
    return np.einsum("abjk,a,b->jk", G, etad, etad) if G.size else np.zeros((4, 3))


def all_link_terms(system, q: np.ndarray) -> list[tuple]:
    """(link index, body, modal indices, J, N) of every massive link at q (n,)."""
    return [(li, body, idx, *link_terms(body, q[idx])) for li, body, idx in mass_links(system)]


def modal_block(A: np.ndarray, Cpp: np.ndarray) -> np.ndarray:
    """(m, m) tr(A C''_ab A^T)."""
    m = Cpp.shape[0]
    return np.sum((A @ Cpp.reshape(m * m, 4, 4)) * A, axis=(1, 2)).reshape(m, m)


def stacked(tree, links, n: int) -> tuple[np.ndarray, np.ndarray]:
    """D (n, L*16): dA/dq of the L massive links side by side, and their J (L, 4, 4).

    Contractions over every massive link, sum_l tr(dA_l,i X_l^T), then become one
    product D @ X.reshape(L*16): the link loop runs inside numpy.
    """
    lis = [item[0] for item in links]
    D = tree.dA[lis].transpose(1, 0, 2, 3).reshape(n, 16 * len(lis))
    return D, np.array([item[3] for item in links]).reshape(-1, 4, 4)


def mass_matrix(system, tree, q: np.ndarray, links=None) -> np.ndarray:
    """(n, n) generalised mass matrix at q.

    Parameters
    ----------
    system : System.
    tree : TreeState at q with dA (``evaluate_tree(..., derivatives=True)``).
    q : (n,) coordinates (rad, m, modal).
    links : :func:`all_link_terms` at q (computed if None).

    Returns
    -------
    M : (n, n) symmetric, kg / kg m / kg m^2 per coordinate units.
    """
    n = system.mechanism.n
    links = all_link_terms(system, q) if links is None else links
    if not links:
        return np.zeros((n, n))
    D, J = stacked(tree, links, n)
    lis = [item[0] for item in links]
    X = (tree.dA[lis] @ J[:, None]).transpose(1, 0, 2, 3).reshape(n, -1)
    M = X @ D.T  # sum_l tr(dA_i J dA_j^T)
    for li, body, idx, _, N in links:
        if idx.size:
            A = tree.A[li]
            # tr(dA_i N_a A^T) = sum_kl dA_i[k, l] (A N_a^T)[k, l]
            cross = tree.dA[li].reshape(n, 16) @ (A @ N.transpose(0, 2, 1)).reshape(-1, 16).T
            M[:, idx] += cross
            M[idx, :] += cross.T
            M[np.ix_(idx, idx)] += modal_block(A, body.Cpp)
    return M
