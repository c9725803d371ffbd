"""The numpy reference of the inertia sums: the oracle of :mod:`pipeline.dynamics.compiled`.

The mass matrix, velocity terms, gravity force and potential and the kinetic energy summed
link by link with numpy, as DESIGN §4 writes them, and J(eta), N(eta) of one body. The
package computes them once, compiled (subtree sums); these are kept here, outside the
package, to test it against (tests/dynamics/test_mass_matrix.py and the others).
"""

from __future__ import annotations

import numpy as np


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
    links = mass_links(system)
    li = np.array([item[0] for item in links], dtype=int)
    J3 = np.array([link_terms(body, q[idx])[0][:, 3] for _, body, idx in links]).reshape(-1, 4)
    return li, J3


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
