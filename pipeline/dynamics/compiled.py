"""The mass matrix, velocity terms, gravity force and potential, and each body's J(eta),
N(eta): the one implementation (numba), on flat arrays, arranged so that its cost grows
with the square of the links of a chain, not its cube. :mod:`mass_matrix`, :mod:`gravity`
and :mod:`energy` are its public faces; the link-by-link numpy form of the same sums is the
tests' oracle (``tests/dynamics/inertia_numpy.py``).

Per link l with modal coordinates eta (m,) and rates eta':

    J = C + sum_a eta_a (C'_a + C'_a^T) + sum_ab eta_a eta_b C''_ab
    N_a = C'_a + sum_b eta_b C''_ba,  Ne = sum_c N_c eta'_c,  G_a = sum_c C''_ac eta'_c
    M_ij += tr(dA_i J dA_j^T),  M_ia += tr(dA_i N_a A^T),  M_ab += tr(A C''_ab A^T)
    h_i += dA_i : Z,  Z = A'' J^T + 2 A' Ne^T
    h_a += A : (A'' N_a + 2 A' G_a^T)
    Q_i += dA_i : (g J[:, 3]^T),  Q_a += (N_a[3, :] A^T) g

with a link's second-order mass moments G (zeros for linear modes), S = sum eta_a eta_b
G_ab / 2: J[:, :3] += S, J[:3, :] += S^T, N_a[:, :3] += sum_b G_ab eta_b, and
Z += A[:, :3] S''^T, S'' = sum eta'_a eta'_b G_ab
(:func:`pipeline.dynamics.mass_matrix.link_terms`).

Composite bodies. A coordinate i local to the step that places link c (its joint's
motions and the modes of the frame it hangs on) moves c and every link below it rigidly
with c: dA_l/dq_i = W A_l, W = (dA_c/dq_i) A_c^{-1}, the same (4, 4) W for the whole
subtree of c. So the sums over links collapse into sums over subtrees,

    M_ij = sum over carriers (c, i) above-or-at (c', j) of W_ci : (W_c'j Jc_c'),
    h_i = W_ci : Hc_c,   Q_i = W_ci : (g mc_c^T),

with the composites Jc_c = sum_{l below c} A_l J_l A_l^T, Hc_c = sum Z_l A_l^T and
mc_c = sum A_l J_l[:, 3], gathered leaves-first. A chain of N links costs N^2 / 2
products of 16 terms instead of the N^3 / 6 of the link-by-link sum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.kinematics.compiled import _kernel as _kinematics
from pipeline.kinematics.compiled import _mm, coordinate_vector

__all__ = ["CompiledMasses", "closed_state", "compile_masses", "gravity_potential",
           "inertia_terms", "link_terms", "reduced_solve", "second_order_acceleration"]


@dataclass(frozen=True)
class CompiledMasses:
    """Mass data of the B massive links, padded to MM modes, and the tree they hang in.

    link (B,) link index; n_modes (B,); idx (B, MM) modal coordinates in q;
    C (B, 4, 4); Cp (B, MM, 4, 4); Cpp (B, MM, MM, 4, 4); G (B, MM, MM, 4, 3) the
    second-order mass moments (zeros where a link has none); has_G (B,) whether a link has
    them (the kernels skip their terms for the others). The tree of the L links: parent
    (L,) the link each hangs from (-1 for the root), order (L - 1,) the other links
    parents-first, n_local (L,) and local (L, KL) the coordinates of the step that places
    each link (Step.local).
    """

    link: np.ndarray
    n_modes: np.ndarray
    idx: np.ndarray
    C: np.ndarray
    Cp: np.ndarray
    Cpp: np.ndarray
    G: np.ndarray
    has_G: np.ndarray
    parent: np.ndarray
    order: np.ndarray
    n_local: np.ndarray
    local: np.ndarray

    def arrays(self) -> tuple:
        """The arrays in the order of the kernels' arguments (after the poses and g)."""
        return (self.link, self.n_modes, self.idx, self.C, self.Cp, self.Cpp, self.G,
                self.has_G, self.parent, self.order, self.n_local, self.local)


def compile_masses(system) -> CompiledMasses:
    """Flatten ``system.mass_links`` and its mechanism's tree (a
    :class:`pipeline.dynamics.System`)."""
    links = system.mass_links
    B = len(links)
    MM = max([1] + [body.n_modes for _, body, _ in links])
    mech = system.mechanism
    steps, slot = mech.table.steps, mech.table.tree_slot
    L = len(mech.links)
    order = np.array(mech.placement[1:], dtype=np.int64)
    KL = max([1] + [steps[slot[li]].local.size for li in order])
    parent = np.full(L, -1, dtype=np.int64)
    n_local = np.zeros(L, dtype=np.int64)
    local = np.zeros((L, KL), dtype=np.int64)
    for li in order:
        st = steps[slot[li]]
        parent[li] = st.frm
        n_local[li] = st.local.size
        local[li, :st.local.size] = st.local
    out = CompiledMasses(np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64),
                         np.zeros((B, MM), dtype=np.int64), np.zeros((B, 4, 4)),
                         np.zeros((B, MM, 4, 4)), np.zeros((B, MM, MM, 4, 4)),
                         np.zeros((B, MM, MM, 4, 3)), np.zeros(B, dtype=np.bool_),
                         parent, order, n_local, local)
    for b, (li, body, idx) in enumerate(links):
        m = body.n_modes
        out.link[b], out.n_modes[b] = li, m
        out.idx[b, :m] = idx
        out.C[b] = body.C
        out.Cp[b, :m] = body.Cp
        out.Cpp[b, :m, :m] = body.Cpp
        if body.second_order_moments.size:
            out.G[b, :m, :m] = body.second_order_moments
            out.has_G[b] = True
    return out


def inertia_terms(cm: CompiledMasses, tree, q: np.ndarray, qd: np.ndarray | None,
                  gravity4: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """M (n, n), h (n,) (None without rates) and the gravity force (n,) at (q, qd).

    ``tree``: TreeState with A, dA (and Ad, Add when qd is given); gravity4 (4,) the
    homogeneous gravity [g, 0], m/s^2 (``System.gravity4``).
    """
    rates = qd is not None
    n = tree.dA.shape[1]
    q = coordinate_vector(q, n, "q")
    Ad = tree.Ad if rates else np.zeros((0, 4, 4))
    Add = tree.Add if rates else np.zeros((0, 4, 4))
    M, h, Qg = _kernel(q, coordinate_vector(qd, n, "qd") if rates else np.zeros(n), rates,
                       np.ascontiguousarray(tree.A), np.ascontiguousarray(tree.dA),
                       np.ascontiguousarray(Ad), np.ascontiguousarray(Add),
                       gravity4, *cm.arrays())
    return M, (h if rates else None), Qg


@njit(cache=True, inline='always')
def _frob(X, Y):
    """X : Y = sum_kl X[k, l] Y[k, l] for 4x4."""
    s = 0.0
    for k in range(4):
        for l in range(4):
            s += X[k, l] * Y[k, l]
    return s


@njit(cache=True, inline='always')
def _mmt_add(X, Y, c, out):
    """out += c X @ Y^T for 4x4."""
    for i in range(4):
        for j in range(4):
            out[i, j] += c * (X[i, 0] * Y[j, 0] + X[i, 1] * Y[j, 1] + X[i, 2] * Y[j, 2]
                              + X[i, 3] * Y[j, 3])


@njit(cache=True, inline='always')
def _atb(X, Y, out):
    """out = X^T Y for 4x4."""
    for i in range(4):
        for j in range(4):
            out[i, j] = X[0, i] * Y[0, j] + X[1, i] * Y[1, j] + X[2, i] * Y[2, j] \
                + X[3, i] * Y[3, j]


@njit(cache=True, inline='always')
def _affine_inverse(A, out):
    """out = A^{-1} for an affine 4x4 [R t; 0 1] (R invertible, not necessarily a
    rotation: a flexible frame's is I + a small skew part)."""
    a, b, c = A[0, 0], A[0, 1], A[0, 2]
    d, e, f = A[1, 0], A[1, 1], A[1, 2]
    g, h, k = A[2, 0], A[2, 1], A[2, 2]
    c0, c1, c2 = e * k - f * h, f * g - d * k, d * h - e * g
    r = 1.0 / (a * c0 + b * c1 + c * c2)
    out[0, 0], out[0, 1], out[0, 2] = c0 * r, (c * h - b * k) * r, (b * f - c * e) * r
    out[1, 0], out[1, 1], out[1, 2] = c1 * r, (a * k - c * g) * r, (c * d - a * f) * r
    out[2, 0], out[2, 1], out[2, 2] = c2 * r, (b * g - a * h) * r, (a * e - b * d) * r
    for i in range(3):
        out[i, 3] = -(out[i, 0] * A[0, 3] + out[i, 1] * A[1, 3] + out[i, 2] * A[2, 3])
        out[3, i] = 0.0
    out[3, 3] = 1.0


@njit(cache=True)
def _body_terms(q, idx, n_modes, C, Cp, Cpp, G, has_G, J, N):
    """J(eta) (B, 4, 4) and N_a(eta) (B, MM, 4, 4) of every body into J, N (the module
    docstring): body b's modal coordinates q[idx[b, :n_modes[b]]], invariants C[b],
    C'_a, C''_ab, second-order moments G[b]. All bodies in one call, indexed rather than
    sliced: a call takes a reference count on each array it is given (an atomic
    operation), which per body cost as much as a rigid body's sums."""
    # written out element by element: as array expressions each 4x4 term allocated a
    # temporary (an 8-mode boom's inertia call: ~100 of them)
    for b in range(n_modes.shape[0]):
        m = n_modes[b]
        for j in range(4):
            for k in range(4):
                J[b, j, k] = C[b, j, k]
        for a in range(m):
            ea = q[idx[b, a]]
            for j in range(4):
                for k in range(4):
                    N[b, a, j, k] = Cp[b, a, j, k]
                    J[b, j, k] += ea * (Cp[b, a, j, k] + Cp[b, a, k, j])
        for a in range(m):
            for c in range(m):
                ec = q[idx[b, c]]
                for j in range(4):
                    for k in range(4):
                        N[b, a, j, k] += ec * Cpp[b, c, a, j, k]
        for a in range(m):
            ea = q[idx[b, a]]
            for j in range(4):
                for k in range(4):
                    # sum_ab eta_a eta_b C''_ba
                    J[b, j, k] += ea * (N[b, a, j, k] - Cp[b, a, j, k])
        # the second-order mass moments: J += S + S^T (S = sum eta_a eta_b G_ab / 2 in
        # the first three columns), N_a[:, :3] += sum_b G_ab eta_b
        for a in range(m if has_G[b] else 0):
            ea = q[idx[b, a]]
            for c in range(m):
                ec = q[idx[b, c]]
                for j in range(4):
                    for k in range(3):
                        v = G[b, a, c, j, k] * ec
                        N[b, a, j, k] += v
                        J[b, j, k] += 0.5 * ea * v
                        J[b, k, j] += 0.5 * ea * v


@njit(cache=True)
def _one_body(eta, C, Cp, Cpp, G, has_G):
    m = eta.shape[0]
    J = np.zeros((1, 4, 4))
    N = np.zeros((1, m, 4, 4))
    _body_terms(eta, np.arange(m).reshape(1, m), np.array([m]), C.reshape(1, 4, 4),
                Cp.reshape(1, m, 4, 4), Cpp.reshape(1, m, m, 4, 4),
                G.reshape(1, m, m, 4, 3), np.array([has_G]), J, N)
    return J[0], N[0]


def link_terms(body, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """J(eta) (4, 4) and N_a = C'_a + sum_b eta_b C''_ba (+ the second-order part) (m, 4, 4)
    of one body (a :class:`pipeline.dynamics.BodyMass`) at its modal coordinates eta (m,):
    the same code the mass matrix, velocity terms and gravity sums run."""
    m = body.n_modes
    G = body.second_order_moments
    has_G = bool(G.size)
    if not has_G:
        G = np.zeros((m, m, 4, 3))
    return _one_body(np.ascontiguousarray(eta, dtype=float).reshape(m),
                     np.ascontiguousarray(body.C, dtype=float),
                     np.ascontiguousarray(body.Cp).reshape(m, 4, 4),
                     np.ascontiguousarray(body.Cpp).reshape(m, m, 4, 4),
                     np.ascontiguousarray(G, dtype=float), has_G)


def second_order_acceleration(body, etad: np.ndarray) -> np.ndarray:
    """(4, 3) S''|eta''=0 = sum_ab eta'_a eta'_b G_ab, int rho xb u2''^T dV at zero modal
    acceleration (body axes); zeros without second-order moments."""
    G = body.second_order_moments
    return np.einsum("abjk,a,b->jk", G, etad, etad) if G.size else np.zeros((4, 3))


@njit(cache=True)
def gravity_potential(q, A, g, mass):
    """V = -sum_b g . (A_b J_b(eta)[:, 3]) (J) over the massive bodies, zero at the ground
    origin: q (n,), A (L, 4, 4) the link poses, g (4,) homogeneous gravity, ``mass`` the
    :meth:`CompiledMasses.arrays`."""
    link, n_modes, idx, C, Cp, Cpp, G, has_G = mass[:8]
    V = 0.0
    J = np.zeros((link.shape[0], 4, 4))
    N = np.zeros((link.shape[0], Cp.shape[1], 4, 4))
    _body_terms(q, idx, n_modes, C, Cp, Cpp, G, has_G, J, N)
    for b in range(link.shape[0]):
        li = link[b]
        for r in range(4):
            s = 0.0
            for k in range(4):
                s += A[li, r, k] * J[b, k, 3]
            V -= g[r] * s
    return V


@njit(cache=True)
def _kernel(q, qd, rates, A, dA, Ad, Add, g, link, n_modes, idx, C, Cp, Cpp, G, has_G,
            parent, order, n_local, local):
    n = q.shape[0]
    L = A.shape[0]
    MM = Cp.shape[1]
    KL = local.shape[1]
    M = np.zeros((n, n))
    h = np.zeros(n)
    Qg = np.zeros(n)
    JB = np.zeros((link.shape[0], 4, 4))
    NB = np.zeros((link.shape[0], MM, 4, 4))
    Gm = np.zeros((MM, 4, 4))
    Z = np.zeros((4, 4))
    T1 = np.zeros((4, 4))
    T2 = np.zeros((4, 4))
    Y = np.zeros((4, 4))
    W = np.zeros((L, KL, 4, 4))
    Jc = np.zeros((L, 4, 4))
    Hc = np.zeros((L, 4, 4))
    mc = np.zeros((L, 4))
    own = np.zeros((L, MM, 4, 4))  # A N_a^T A^T of each massive flexible link's modes
    massive = np.full(L, -1)
    # W of every carrier: the rigid motion that coordinate local[c, k] gives c's subtree
    for o in range(order.shape[0]):
        c = order[o]
        if n_local[c]:
            _affine_inverse(A[c], T1)
            for k in range(n_local[c]):
                _mm(dA[c, local[c, k]], T1, W[c, k])
    _body_terms(q, idx, n_modes, C, Cp, Cpp, G, has_G, JB, NB)
    for b in range(link.shape[0]):
        li, m = link[b], n_modes[b]
        massive[li] = b
        J, N = JB[b], NB[b]
        Al = A[li]
        # this link's share of its composites: A J A^T and A J[:, 3]
        _mm(Al, J, T1)
        _mmt_add(T1, Al, 1.0, Jc[li])
        for r in range(4):
            mc[li, r] += T1[r, 3]
        if m:
            _atb(Al, Al, Y)  # A^T A: M_ab = (A C''_ab) : A = (A^T A) : C''_ab
        for a in range(m):
            ia = idx[b, a]
            # own[a] = A N_a^T A^T (for M_ia += W_i : own[a])
            T1[:] = 0.0
            _mmt_add(Al, N[a], 1.0, T1)
            _mmt_add(T1, Al, 1.0, own[li, a])
            for c in range(a, m):  # C''_ba = C''_ab^T and A^T A symmetric: M_ba = M_ab
                v = _frob(Y, Cpp[b, a, c])
                M[ia, idx[b, c]] += v
                if c != a:
                    M[idx[b, c], ia] += v
            s = 0.0
            for k in range(4):
                for j in range(4):
                    s += N[a, 3, j] * Al[k, j] * g[k]
            Qg[ia] += s
        if not rates:
            continue
        # Z = A'' J^T + 2 A' Ne^T (+ A[:, :3] S''^T); the composite gathers Z A^T
        Z[:] = 0.0
        _mmt_add(Add[li], J, 1.0, Z)
        if m:
            T1[:] = 0.0
            for c in range(m):
                w = qd[idx[b, c]]
                for j in range(4):
                    for k in range(4):
                        T1[j, k] += w * N[c, j, k]
            _mmt_add(Ad[li], T1, 2.0, Z)
            # Z += A[:, :3] S''^T, S'' = sum eta'_a eta'_b G_ab
            for j in range(4 if has_G[b] else 0):
                for k in range(3):
                    sjk = 0.0
                    for a in range(m):
                        for c in range(m):
                            sjk += G[b, a, c, j, k] * qd[idx[b, a]] * qd[idx[b, c]]
                    if sjk != 0.0:
                        for r in range(4):
                            Z[r, j] += Al[r, k] * sjk
        _mmt_add(Z, Al, 1.0, Hc[li])
        # h_a += A : (A'' N_a + 2 A' G_a^T) = (A''^T A) : N_a + 2 (A'^T A) : G_a^T,
        # G_a = sum_c C''_ac eta'_c
        if m:
            _atb(Add[li], Al, T1)
            _atb(Ad[li], Al, T2)
        for a in range(m):
            Gm[a] = 0.0
            for c in range(m):
                w = qd[idx[b, c]]
                for j in range(4):
                    for k in range(4):
                        Gm[a, j, k] += w * Cpp[b, a, c, j, k]
            v = _frob(T1, N[a])
            for k in range(4):
                for j in range(4):
                    v += 2.0 * T2[k, j] * Gm[a, j, k]
            h[idx[b, a]] += v
    # composites, leaves first
    for o in range(order.shape[0] - 1, -1, -1):
        c = order[o]
        p = parent[c]
        Jc[p] += Jc[c]
        mc[p] += mc[c]
        if rates:
            Hc[p] += Hc[c]
    for o in range(order.shape[0]):
        c = order[o]
        for k in range(n_local[c]):
            i = local[c, k]
            Wk = W[c, k]
            # M_ij over the carriers (e, j) at or above (c, i): W_ej : (W_ci Jc_c)
            _mm(Wk, Jc[c], Y)
            e = c
            kk = k
            while e >= 0:
                for k2 in range(kk + 1):
                    j = local[e, k2]
                    v = _frob(W[e, k2], Y)
                    M[j, i] += v
                    if e != c or k2 != k:
                        M[i, j] += v
                e = parent[e]
                kk = n_local[e] - 1 if e >= 0 else -1
            s = 0.0
            for r in range(4):
                for l in range(4):
                    s += Wk[r, l] * g[r] * mc[c, l]
            Qg[i] += s
            if rates:
                h[i] += _frob(Wk, Hc[c])
        # M_ia of this link's own modes with the carriers at or above it
        b = massive[c]
        if b >= 0:
            for a in range(n_modes[b]):
                ia = idx[b, a]
                e = c
                while e >= 0:
                    for k2 in range(n_local[e]):
                        j = local[e, k2]
                        v = _frob(W[e, k2], own[c, a])
                        M[j, ia] += v
                        M[ia, j] += v
                    e = parent[e]
    return M, h, Qg


# --------------------------------------------------------------------------- fused state
def closed_state(kin, masses: CompiledMasses, q_guess: np.ndarray, rows: np.ndarray,
                 dep: np.ndarray, cols: np.ndarray, rates_cols: np.ndarray,
                 accels_cols: np.ndarray, weights: np.ndarray, tol: float, gravity4: np.ndarray,
                 max_iter: int = 6, max_move: float = 0.2):
    """One machine-code pass for a reduced state of a closed-loop system.

    Newton on the dependent coordinates ``dep`` (closure rows ``rows``, weighted max-norm
    tolerance ``tol`` with row ``weights``) from ``q_guess`` (n,), whose other entries are
    final; then the velocity map X = dq/dq[cols] (n, c), q' = X rates_cols, the closure
    gamma, the acceleration part c (n,) of q'' = X q''[cols] + c with q''[cols] =
    ``accels_cols`` where given (the drivers; zero for the unknown ones), and M, h and
    the gravity force (gravity4: (4,) homogeneous, m/s^2) at (q, q').

    Returns None if the plain Newton did not converge fast (``max_iter`` iterations, each
    halving the residual and moving no dependent coordinate by more than ``max_move`` rad
    or m): the caller falls back to the damped, least-squares-backed position analysis;
    else
    (q, r, J, X, qd, c, A, dA, Ad, Add, M, h, Qg).
    """
    out = _closed_state(np.array(q_guess, dtype=float), rows, dep, cols,
                        np.ascontiguousarray(rates_cols, dtype=float),
                        np.ascontiguousarray(accels_cols, dtype=float), weights, tol, max_iter,
                        max_move, gravity4, kin.arrays(), masses.arrays())
    return out[1:] if out[0] else None


@njit(cache=True)
def _closed_state(q, rows, dep, cols, rates_cols, accels_cols, weights, tol, max_iter,
                  max_move, g, kin, mass):
    n = q.shape[0]
    nd, nc = dep.shape[0], cols.shape[0]
    qd = np.zeros(n)
    ok = False
    prev = np.inf
    for it in range(max_iter + 1):
        A, dA, Ad, Add, r, J, gam = _kinematics(q, qd, False, *kin)
        err = 0.0
        for i in range(r.shape[0]):
            err = max(err, abs(weights[i] * r[i]))
        if err <= tol:
            ok = True
            break
        # plain Newton only where it converges fast (near the guess): anything else goes to
        # the damped position analysis, so that no far assembly branch is ever jumped to
        if it == max_iter or err > 0.5 * prev:
            break
        prev = err
        R = np.empty((nd, nd))
        b = np.empty(nd)
        for a in range(nd):
            b[a] = -r[rows[a]]
            for c in range(nd):
                R[a, c] = J[rows[a], dep[c]]
        dx = np.linalg.solve(R, b)
        big = 0.0
        for c in range(nd):
            big = max(big, abs(dx[c]))
        if big > max_move:
            break
        for c in range(nd):
            q[dep[c]] += dx[c]
    X = np.zeros((n, nc))
    cacc = np.zeros(n)
    if not ok:
        return False, q, r, J, X, qd, cacc, A, dA, Ad, Add, np.zeros((n, n)), np.zeros(n), \
            np.zeros(n)
    R = np.empty((nd, nd))
    rhs = np.empty((nd, nc))
    for a in range(nd):
        for c in range(nd):
            R[a, c] = J[rows[a], dep[c]]
        for c in range(nc):
            rhs[a, c] = -J[rows[a], cols[c]]
    for c in range(nc):
        X[cols[c], c] = 1.0
    lu_solve_rhs = np.linalg.solve(R, rhs)
    for a in range(nd):
        for c in range(nc):
            X[dep[a], c] = lu_solve_rhs[a, c]
    for i in range(n):
        s = 0.0
        for c in range(nc):
            s += X[i, c] * rates_cols[c]
        qd[i] = s
    A, dA, Ad, Add, _, _, gam = _kinematics(q, qd, True, *kin)
    # c: q'' with the unknown q''[cols] = 0, i.e. R_dep c_dep = gamma - R_cols accels_cols
    b = np.empty(nd)
    for a in range(nd):
        s = gam[rows[a]]
        for c in range(nc):
            s += rhs[a, c] * accels_cols[c]
        b[a] = s
    cd = np.linalg.solve(R, b)
    for c in range(nc):
        cacc[cols[c]] = accels_cols[c]
    for a in range(nd):
        cacc[dep[a]] = cd[a]
    M, h, Qg = _kernel(q, qd, True, A, dA, Ad, Add, g, *mass)
    return True, q, r, J, X, qd, cacc, A, dA, Ad, Add, M, h, Qg


@njit(cache=True)
def reduced_solve(B, Bp, M, rhs, c):
    """(q''_I, q'', driver forces) of (B^T M B) q''_I = B^T (rhs - M c), q'' = B q''_I + c,
    lambda = B_p^T (M q'' - rhs); B (n, nI), B_p (n, p), M (n, n), rhs, c (n,)."""
    Bt = np.ascontiguousarray(B.T)
    qdd_I = np.linalg.solve(Bt @ (M @ B), Bt @ (rhs - M @ c))
    qdd = B @ qdd_I + c
    lam = np.ascontiguousarray(Bp.T) @ (M @ qdd - rhs)
    return qdd_I, qdd, lam
