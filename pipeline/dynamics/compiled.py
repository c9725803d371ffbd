"""Compiled mass matrix, velocity terms and gravity force (numba).

The same sums as :mod:`mass_matrix`, :mod:`velocity_terms` and :mod:`gravity`
(the reference implementation, kept for clarity and for the tests comparing
the two), as one loop over the massive links on flat arrays. Why: in numpy
the per-link 4x4 products are call overhead, not arithmetic (front-end loader:
~0.35 ms per state in numpy, a few us compiled).

Per link l with modal coordinates eta (m,) and rates eta':

    J = C + sum_a eta_a (C'_a + C'_a^T) + sum_ab eta_a eta_b C''_ab
    N_a = C'_a + sum_b eta_b C''_ba,  Ne = sum_c N_c eta'_c,  G_a = sum_c C''_ac eta'_c
    M_ij += tr(dA_i J dA_j^T),  M_ia += tr(dA_i N_a A^T),  M_ab += tr(A C''_ab A^T)
    h_i += tr(dA_i (A'' J^T + 2 A' Ne^T)^T)... i.e. dA_i : (A'' J^T + 2 A' Ne^T)
    h_a += A : (A'' N_a + 2 A' G_a^T)
    Q_i += dA_i : (g J[:, 3]^T),  Q_a += (N_a[3, :] A^T) g

with a link's second-order mass moments G (zeros for linear modes), S = sum eta_a eta_b
G_ab / 2: J[:, :3] += S, J[:3, :] += S^T, N_a[:, :3] += sum_b G_ab eta_b, and
h_i += dA_i : (A[:, :3] S''^T), S'' = sum eta'_a eta'_b G_ab
(:func:`pipeline.dynamics.mass_matrix.link_terms`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.kinematics.compiled import _kernel as _kinematics
from pipeline.kinematics.compiled import _mm, coordinate_vector

__all__ = ["CompiledMasses", "closed_state", "compile_masses", "inertia_terms", "reduced_solve"]


@dataclass(frozen=True)
class CompiledMasses:
    """Mass data of the B massive links, padded to MM modes.

    link (B,) link index; n_modes (B,); idx (B, MM) modal coordinates in q;
    C (B, 4, 4); Cp (B, MM, 4, 4); Cpp (B, MM, MM, 4, 4); G (B, MM, MM, 4, 3) the
    second-order mass moments (zeros where a link has none); has_G (B,) whether a link has
    them (the kernels skip their terms for the others).
    """

    link: np.ndarray
    n_modes: np.ndarray
    idx: np.ndarray
    C: np.ndarray
    Cp: np.ndarray
    Cpp: np.ndarray
    G: np.ndarray
    has_G: np.ndarray


def compile_masses(system) -> CompiledMasses:
    """Flatten ``system.mass_links`` (a :class:`pipeline.dynamics.System`)."""
    links = system.mass_links
    B = len(links)
    MM = max([1] + [body.n_modes for _, body, _ in links])
    out = CompiledMasses(np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64),
                         np.zeros((B, MM), dtype=np.int64), np.zeros((B, 4, 4)),
                         np.zeros((B, MM, 4, 4)), np.zeros((B, MM, MM, 4, 4)),
                         np.zeros((B, MM, MM, 4, 3)), np.zeros(B, dtype=np.bool_))
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
                       gravity4, cm.link, cm.n_modes,
                       cm.idx, cm.C, cm.Cp, cm.Cpp, cm.G, cm.has_G)
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


@njit(cache=True)
def _kernel(q, qd, rates, A, dA, Ad, Add, g, link, n_modes, idx, C, Cp, Cpp, G, has_G):
    n = q.shape[0]
    MM = Cp.shape[1]
    M = np.zeros((n, n))
    h = np.zeros(n)
    Qg = np.zeros(n)
    X = np.zeros((n, 4, 4))
    J = np.zeros((4, 4))
    N = np.zeros((MM, 4, 4))
    Gm = np.zeros((MM, 4, 4))
    Z = np.zeros((4, 4))
    T1 = np.zeros((4, 4))
    T2 = np.zeros((4, 4))
    nz = np.empty(n, dtype=np.int64)
    for b in range(link.shape[0]):
        li, m = link[b], n_modes[b]
        # the coordinates this link's pose depends on (dA_i = 0 for the others: their terms
        # are exact zeros, skipped)
        cnt = 0
        for i in range(n):
            for k in range(16):
                if dA[li, i, k // 4, k % 4] != 0.0:
                    nz[cnt] = i
                    cnt += 1
                    break
        # J(eta) and N_a(eta)
        J[:] = C[b]
        for a in range(m):
            N[a] = Cp[b, a]
            ea = q[idx[b, a]]
            J += ea * (Cp[b, a] + Cp[b, a].T)
        for a in range(m):
            for c in range(m):
                N[a] += q[idx[b, c]] * Cpp[b, c, a]
        for a in range(m):
            J += q[idx[b, a]] * (N[a] - Cp[b, a])  # sum_ab eta_a eta_b C''_ba
        # the second-order mass moments: J += S + S^T (S = sum eta_a eta_b G_ab / 2 in
        # the first three columns), N_a[:, :3] += sum_b G_ab eta_b
        for a in range(m if has_G[b] else 0):
            ea = q[idx[b, a]]
            for c in range(m):
                ec = q[idx[b, c]]
                for j in range(4):
                    for k in range(3):
                        v = G[b, a, c, j, k] * ec
                        N[a, j, k] += v
                        J[j, k] += 0.5 * ea * v
                        J[k, j] += 0.5 * ea * v
        Al = A[li]
        # M_ij += (dA_i J) : dA_j
        for ii in range(cnt):
            i = nz[ii]
            _mm(dA[li, i], J, X[i])
        for ii in range(cnt):
            i = nz[ii]
            for jj in range(ii, cnt):
                j = nz[jj]
                v = _frob(X[i], dA[li, j])
                M[i, j] += v
                if j != i:
                    M[j, i] += v
        # gravity: dA_i : (g J[:, 3]^T)
        for ii in range(cnt):
            i = nz[ii]
            s = 0.0
            for k in range(4):
                for l in range(4):
                    s += dA[li, i, k, l] * g[k] * J[l, 3]
            Qg[i] += s
        for a in range(m):
            ia = idx[b, a]
            # M_ia += dA_i : (A N_a^T); M_ab += (A C''_ab) : A
            T1[:] = 0.0
            _mmt_add(Al, N[a], 1.0, T1)
            for ii in range(cnt):
                i = nz[ii]
                v = _frob(dA[li, i], T1)
                M[i, ia] += v
                M[ia, i] += v
            for c in range(m):
                _mm(Al, Cpp[b, a, c], T2)
                M[ia, idx[b, c]] += _frob(T2, Al)
            s = 0.0
            for k in range(4):
                for j in range(4):
                    s += N[a, 3, j] * Al[k, j] * g[k]
            Qg[ia] += s
        if not rates:
            continue
        # h_i += dA_i : (A'' J^T + 2 A' Ne^T)
        Z[:] = 0.0
        _mmt_add(Add[li], J, 1.0, Z)
        if m:
            T1[:] = 0.0
            for c in range(m):
                T1 += qd[idx[b, c]] * N[c]
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
        for ii in range(cnt):
            h[nz[ii]] += _frob(dA[li, nz[ii]], Z)
        # h_a += A : (A'' N_a + 2 A' G_a^T),  G_a = sum_c C''_ac eta'_c
        for a in range(m):
            Gm[a] = 0.0
            for c in range(m):
                Gm[a] += qd[idx[b, c]] * Cpp[b, a, c]
            _mm(Add[li], N[a], T2)
            _mmt_add(Ad[li], Gm[a], 2.0, T2)
            h[idx[b, a]] += _frob(Al, T2)
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
                        max_move, gravity4, kin.arrays(), masses.link,
                        masses.n_modes, masses.idx, masses.C, masses.Cp, masses.Cpp,
                        masses.G, masses.has_G)
    return out[1:] if out[0] else None


@njit(cache=True)
def _closed_state(q, rows, dep, cols, rates_cols, accels_cols, weights, tol, max_iter,
                  max_move, g, kin, link, m_modes, idx, C, Cp, Cpp, G, has_G):
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
    M, h, Qg = _kernel(q, qd, True, A, dA, Ad, Add, g, link, m_modes, idx, C, Cp, Cpp, G,
                       has_G)
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
