"""Compiled index-3 generalised-alpha steps (numba; the method: :mod:`pipeline.solver.index3`),
the one implementation of its Newton iteration, run as one machine-code call per stretch
of steps. The equations are those of :class:`~pipeline.solver.constrained.ConstrainedSystem`
(the numpy reference, tested equal); the same step written in numpy is the oracle in
``tests/solver/index3_numpy.py``.

Why: a step of a small machine is a few hundred small-array operations (poses, mass matrix,
closure rows, a saddle-point solve, Newton bookkeeping); in Python their call overhead is
~50x their arithmetic. Here a step of the rigid four-bar costs a few microseconds.

Arguments are grouped in tuples: ``kin`` the CompiledMechanism arrays in the order of
:func:`kin_tuple`, ``mass`` the CompiledMasses arrays, ``frc`` the force elements' ForceData
(:mod:`pipeline.dynamics.forces.compiled`) and ``par`` the scalar settings
(alpha_m, alpha_f, beta, gamma, rtol, atol, closure_tol, jump, eps, and the first-order
alpha_m and gamma of the elements' states).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.dynamics.compiled import _kernel as _inertia
from pipeline.dynamics.compiled import gravity_potential
from pipeline.dynamics.forces.compiled import generalized_forces, potential, state_rates
from pipeline.kinematics.compiled import _kernel as _kinematics
from pipeline.solver.generalized_alpha import NEWTON_SHARE, REFRESH_AFTER

__all__ = ["kin_tuple", "march", "mass_tuple", "output", "start", "step", "terms"]

MAX_NEWTON = 12
# a step that has not converged after REFRESH_AFTER modified-Newton iterations (one
# definition for both generalised-alpha steps: pipeline.solver.generalized_alpha) refreshes
# its iteration matrix (n evaluations by finite differences) before the next one, and
# accepts the user's tolerance from then on


def kin_tuple(cm) -> tuple:
    """The CompiledMechanism's arrays in the kernels' order."""
    return cm.arrays()


def mass_tuple(cm) -> tuple:
    return cm.arrays()


@njit(cache=True)
def terms(q, v, z, factor, kin, mass, K, D, g, w, frc):
    """(M (n, n), rhs (n,), Q_nc (n,), c (m,), C (m, n), gamma (m,), z' (nz,)) at (q, v)
    and the elements' states z: the equations M q'' + C^T lambda = rhs, c = w Phi,
    C = dc/dq, C q'' = gamma (weighted), and the states' rates."""
    return _terms(q, v, z, factor, kin, mass, K, D, g, w, frc)[:7]


@njit(cache=True, inline='always')
def _terms(q, v, z, factor, kin, mass, K, D, g, w, frc):
    """:func:`terms` and the link poses A, dA and the closure residual r used."""
    A, dA, Ad, Add, r, J, gam = _kinematics(q, v, True, *kin)
    M, hv, Qg = _inertia(q, v, True, A, dA, Ad, Add, g, *mass)
    n = q.shape[0]
    Dv, Kq = _mv(D, v), _mv(K, q)
    Qnc = -Dv
    rhs = np.empty(n)
    for i in range(n):  # the elements' forces are added below
        rhs[i] = Qg[i] - Kq[i] - Dv[i] - hv[i]
    if frc.kind.shape[0]:
        Qf = np.zeros(n)
        generalized_forces(q, v, z, A, dA, factor, frc, Qf, Qnc)
        for i in range(n):
            rhs[i] += Qf[i]
    zd = np.zeros(z.shape[0])
    if z.shape[0]:
        state_rates(q, v, z, A, dA, factor, frc, zd)
    m = r.shape[0]
    c = np.empty(m)
    C = np.empty((m, q.shape[0]))
    gw = np.empty(m)
    for i in range(m):
        c[i] = w[i] * r[i]
        gw[i] = w[i] * gam[i]
        for j in range(q.shape[0]):
            C[i, j] = w[i] * J[i, j]
    return M, rhs, Qnc, c, C, gw, zd, A, dA, r


@njit(cache=True)
def _mv(A, x):
    """A @ x (A (n, k) C-contiguous): written out for a small A, where a BLAS call costs
    more than its arithmetic (the rigid four-bar's step: 17.3 -> 14.9 us with the sums
    below written out), BLAS for a large one (a flexible machine's modal coordinates)."""
    if A.shape[0] * A.shape[1] > 400:
        return A @ x
    out = np.zeros(A.shape[0])
    for i in range(A.shape[0]):
        s = 0.0
        for j in range(A.shape[1]):
            s += A[i, j] * x[j]
        out[i] = s
    return out


@njit(cache=True)
def _residual_rows(M, rhs, C, qdd, lam, rows):
    """(M q'' - rhs + C^T lambda)[rows]: the dynamic residual on the unknowns U (Newton),
    or the generalized forces the drivers apply on P."""
    R = _mv(M, qdd) - rhs
    for i in range(C.shape[0]):
        for j in range(C.shape[1]):
            R[j] += C[i, j] * lam[i]
    out = np.empty(rows.shape[0])
    for k in range(rows.shape[0]):
        out[k] = R[rows[k]]
    return out


@njit(cache=True)
def _lu(A):
    """In-place LU with partial pivoting of a small dense matrix: (LU, pivots); raises
    ZeroDivisionError on an exactly singular pivot. (For the few-dozen unknowns of a step,
    cheaper than a LAPACK call's copies and checks.)"""
    n = A.shape[0]
    piv = np.arange(n)
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big, p = abs(A[i, k]), i
        if big == 0.0:
            raise ZeroDivisionError("singular iteration matrix")
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            piv[k], piv[p] = piv[p], piv[k]
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
    return A, piv


@njit(cache=True)
def _lu_solve(LU, piv, b):
    n = LU.shape[0]
    x = np.empty(n)
    for i in range(n):
        x[i] = b[piv[i]]
    for i in range(n):
        s = x[i]
        for j in range(i):
            s -= LU[i, j] * x[j]
        x[i] = s
    for i in range(n - 1, -1, -1):
        s = x[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * x[j]
        x[i] = s / LU[i, i]
    return x


@njit(cache=True)
def _saddle_factor(S, CU, eps):
    """(K, LU, pivots, s) of the regularised saddle-point matrix K = [[S, s C^T],
    [s C, -eps s I]] (s the largest diagonal entry of S: the rows' common scale)."""
    k, m = S.shape[0], CU.shape[0]
    s = 0.0
    for i in range(k):
        s = max(s, abs(S[i, i]))
    if s == 0.0:
        s = 1.0
    Kr = np.zeros((k + m, k + m))
    Kr[:k, :k] = S
    Kr[:k, k:] = s * CU.T
    Kr[k:, :k] = s * CU
    for i in range(m):
        Kr[k + i, k + i] = -eps * s
    LU, piv = _lu(Kr.copy())
    return Kr, LU, piv, s


@njit(cache=True)
def _saddle_solve(Kr, LU, piv, s, f, g, eps, refine):
    """(x, lambda) of S x + C^T lambda = f, C x = g on the factors of
    :func:`_saddle_factor`, with ``refine`` steps of iterative refinement towards the
    unregularised system (the regularised factors its preconditioner)."""
    k, m = f.shape[0], g.shape[0]
    b = np.concatenate((f, s * g))
    z = _lu_solve(LU, piv, b)
    for _ in range(refine):
        r = b - Kr @ z
        for i in range(m):
            r[k + i] -= eps * s * z[k + i]
        z = z + _lu_solve(LU, piv, r)
    return z[:k], s * z[k:]


@njit(cache=True)
def _saddle(S, CU, f, g, eps, refine):
    """(x, lambda) of S x + C^T lambda = f, C x = g by the regularised, refined solve
    (constrained.saddle_solve_regularised)."""
    Kr, LU, piv, s = _saddle_factor(S, CU, eps)
    return _saddle_solve(Kr, LU, piv, s, f, g, eps, refine)


@njit(cache=True)
def _reduced(M, rhs, C, gw, aP, U, P):
    """The index-1 system on the integrated coordinates U with the driven accelerations aP
    known: (q'' (n,) with its P entries set, M_UU, f = (rhs - M q'')_U, C_U,
    g = gamma - C q'')."""
    n, nU, m = M.shape[0], U.shape[0], C.shape[0]
    qdd = np.zeros(n)
    for k in range(P.shape[0]):
        qdd[P[k]] = aP[k]
    Mq = M @ qdd
    f = np.empty(nU)
    MUU = np.empty((nU, nU))
    for a in range(nU):
        f[a] = rhs[U[a]] - Mq[U[a]]
        for b in range(nU):
            MUU[a, b] = M[U[a], U[b]]
    g = gw - C @ qdd if m else np.zeros(0)
    return qdd, MUU, f, _sub(C, U), g


@njit(cache=True)
def _index1(M, rhs, C, gw, aP, U, P, eps):
    """(q'' (n,), lambda (m,)) of the index-1 system by the regularised, refined solve
    (constrained.ConstrainedSystem.accelerations with eps)."""
    qdd, MUU, f, CU, g = _reduced(M, rhs, C, gw, aP, U, P)
    x, lam = _saddle(MUU, CU, f, g, eps, 2)
    for a in range(U.shape[0]):
        qdd[U[a]] = x[a]
    return qdd, lam


@njit(cache=True)
def _powers(M, rhs, Qnc, C, gw, v, aP, U, P, eps):
    """(driver power, -dissipated power) W at a state, the driver forces from the index-1
    accelerations and multipliers there."""
    pnc = 0.0
    for i in range(v.shape[0]):
        pnc += Qnc[i] * v[i]
    held = True  # drivers at rest do no work: no index-1 solve for it (a held slew)
    for k in range(P.shape[0]):
        if v[P[k]] != 0.0:
            held = False
    if held:
        return 0.0, -pnc
    qdd, lam = _index1(M, rhs, C, gw, aP, U, P, eps)
    FP = _residual_rows(M, rhs, C, qdd, lam, P)
    pd = 0.0
    for k in range(P.shape[0]):
        pd += FP[k] * v[P[k]]
    return pd, -pnc


@njit(cache=True)
def step(q0, v0, qdd0, a0, lam0, z0, zd0, b0, h, qP, vP, aP, factor, par, unit, zunit, U, P,
         S, sinfo, kin, mass, K, D, g, w, frc):
    """One step of size h from (q0, v0, qdd0, a0, lam0) and the elements' states (z0, their
    rates zd0, their acceleration-like variable b0) (the method of index3; the states
    by first-order generalised-alpha, par[9:11] = its alpha_m and gamma, in the same Newton
    iteration: unknowns q_U and z, the states' residual z' - f(q, v, z) scaled by c_z).

    ``S`` (nU + nz, nU + nz) is the scaled iteration matrix, refreshed in place; ``sinfo`` =
    [h of S, stale flag, Jacobians, evaluations] is updated in place. Returns (status, q, v,
    qdd, a, lam, z, zd, b, iterations, largest correction, closure residual, driver power,
    -dissipated power); status 0 converged, 1 Newton failed, 2 jump (another branch),
    3 non-finite.
    """
    am, af, beta, gamma = par[0], par[1], par[2], par[3]
    rtol, atol, ctol, jump, eps = par[4], par[5], par[6], par[7], par[8]
    amz, gz = par[9], par[10]
    bp = (1.0 - am) / (beta * h * h * (1.0 - af))
    gp = gamma / (beta * h)
    cz = (1.0 - amz) / (gz * h * (1.0 - af))  # d z' / d z along the Newton direction
    nU, m, nz = U.shape[0], w.shape[0], z0.shape[0]
    nk = nU + nz
    qdd = qdd0.copy()
    for k in range(P.shape[0]):
        qdd[P[k]] = aP[k]
    a1 = (af * qdd0 - am * a0 + (1.0 - af) * qdd) / (1.0 - am)
    q = q0 + h * v0 + h * h * ((0.5 - beta) * a0 + beta * a1)
    v = v0 + h * ((1.0 - gamma) * a0 + gamma * a1)
    for k in range(P.shape[0]):
        q[P[k]] = qP[k]
        v[P[k]] = vP[k]
    zd = zd0.copy()
    b1 = (zd0 - amz * b0) / (1.0 - amz)
    z = z0 + h * ((1.0 - gz) * b0 + gz * b1)
    qpred = q.copy()
    lam = lam0.copy()
    tol = np.empty(nk)
    for k in range(nU):
        tol[k] = atol * unit[U[k]] + rtol * abs(q[U[k]])
    for k in range(nz):
        tol[nU + k] = atol * zunit[k] + rtol * abs(z[k])
    refreshed = False
    prev = 0.0
    cerr = np.inf
    moved = 0.0
    R = np.empty(nk)
    factored = False
    Kr = LU = np.empty((0, 0))
    piv = np.empty(0, dtype=np.int64)
    sc = 1.0
    M, rhs, Qnc, c, C, gw, f = terms(q, v, z, factor, kin, mass, K, D, g, w, frc)
    for it in range(MAX_NEWTON):
        if it:
            M, rhs, Qnc, c, C, gw, f = terms(q, v, z, factor, kin, mass, K, D, g, w, frc)
        sinfo[3] += 1.0
        G = _residual_rows(M, rhs, C, qdd, lam, U)
        for k in range(nU):
            R[k] = G[k] / bp
        for k in range(nz):
            R[nU + k] = (zd[k] - f[k]) / cz
        cerr = 0.0
        for i in range(m):
            cerr = max(cerr, abs(c[i]))
        if not (np.all(np.isfinite(R)) and np.isfinite(cerr)):
            return 3, q, v, qdd, a1, lam, z, zd, b1, it, moved, cerr, 0.0, 0.0
        ratio = h / sinfo[0] if sinfo[0] > 0 else 0.0
        if sinfo[0] <= 0 or ratio < 0.5 or ratio > 2.0 or sinfo[1] > 0 or \
                (it == REFRESH_AFTER and not refreshed):
            _jacobian(q, v, qdd, lam, z, zd, G, zd - f, M, bp, gp, cz, factor, unit, zunit,
                      U, S, kin, mass, K, D, g, w, frc)
            sinfo[0], sinfo[1] = h, 0.0
            sinfo[2] += 1.0
            sinfo[3] += nk
            refreshed = True
            factored = False
        if not factored:
            # factored once a step (and again after a refresh): the mass and constraint
            # rows change by the iterations' small corrections only, while the LU of a
            # chain of 64 bars costs as much as an evaluation of its equations
            CU = np.zeros((m, nk))
            for i in range(m):
                for kk in range(nU):
                    CU[i, kk] = C[i, U[kk]]
            Kr, LU, piv, sc = _saddle_factor(_with_mass(S, M, U), CU, eps)
            factored = True
        x, dl = _saddle_solve(Kr, LU, piv, sc, -R, -c, eps, 0)
        if not np.all(np.isfinite(x)):
            return 1, q, v, qdd, a1, lam, z, zd, b1, it + 1, moved, cerr, 0.0, 0.0
        moved = 0.0
        for kk in range(nU):
            i = U[kk]
            q[i] += x[kk]
            v[i] += gp * x[kk]
            qdd[i] += bp * x[kk]
            moved = max(moved, abs(q[i] - qpred[i]) / unit[i])
        for k in range(nz):
            z[k] += x[nU + k]
            zd[k] += cz * x[nU + k]
        lam += bp * dl
        if moved > jump:
            return 2, q, v, qdd, a1, lam, z, zd, b1, it + 1, moved, cerr, 0.0, 0.0
        norm, user = 0.0, 0.0
        for kk in range(nU):
            i = U[kk]
            eloc = abs((beta - 1.0 / 6.0) * h * h * (qdd[i] - qdd0[i]))
            tl = min(tol[kk], max(NEWTON_SHARE * eloc, 1e-14 * (abs(q[i]) + unit[i])))
            norm = max(norm, abs(x[kk]) / tl)
            user = max(user, abs(x[kk]) / tol[kk])
        for k in range(nz):  # the states' local error is O(h^2 (z'_1 - z'_0)) likewise
            eloc = abs((gz - 0.5) * h * (zd[k] - zd0[k]))
            tl = min(tol[nU + k], max(NEWTON_SHARE * eloc, 1e-14 * (abs(z[k]) + zunit[k])))
            norm = max(norm, abs(x[nU + k]) / tl)
            user = max(user, abs(x[nU + k]) / tol[nU + k])
        theta = norm / prev if prev > 0 else 0.0
        if theta >= 1.0 and it >= 2 and not refreshed:
            sinfo[1] = 1.0
        left = norm * theta / (1.0 - theta) if 0.0 < theta < 1.0 else norm
        prev = norm
        enough = it >= REFRESH_AFTER and user <= 1.0
        if (left <= 1.0 or norm <= 1e-3 or enough) and cerr <= ctol:
            if it >= REFRESH_AFTER:
                sinfo[1] = 1.0
            a_new = a1 + (1.0 - af) / (1.0 - am) * (qdd - qdd0)
            for k in range(P.shape[0]):
                a_new[P[k]] = aP[k]
            b_new = b1 + (1.0 - af) / (1.0 - amz) * (zd - zd0)
            pd, pnc = _powers(M, rhs, Qnc, C, gw, v, aP, U, P, eps)
            return 0, q, v, qdd, a_new, lam, z, zd, b_new, it + 1, moved, cerr, pd, pnc
    sinfo[1] = 1.0
    return 1, q, v, qdd, a1, lam, z, zd, b1, MAX_NEWTON, moved, cerr, 0.0, 0.0


@njit(cache=True)
def _with_mass(S, M, U):
    """The iteration matrix: the kept remainder S (nk, nk) plus the mass matrix M_UU (of
    the step's first iterate) in its dynamic block."""
    St = S.copy()
    for a in range(U.shape[0]):
        for b in range(U.shape[0]):
            St[a, b] += M[U[a], U[b]]
    return St


@njit(cache=True)
def _jacobian(q, v, qdd, lam, z, zd, G, H, M, bp, gp, cz, factor, unit, zunit, U, S, kin,
              mass, K, D, g, w, frc):
    """S (nU + nz, nU + nz) = dR/dx by forward differences along the Newton direction: a
    change d of q_i moves v_i by gamma' d and q''_i by beta' d; one of z_k moves z'_k by
    c_z d (R = [G / beta', H / c_z] the scaled residual of :func:`step`: G the dynamic
    rows on U, H = z' - f the states'), less the mass matrix M_UU at q in its dynamic block.

    Why the mass matrix is taken out: it is the largest part of the dynamic block (the
    rest is O(h) damping and gyroscopic terms and O(h^2) stiffness), and the one that
    changes fastest as a machine moves. :func:`step` adds the step's own M_UU back
    (:func:`_with_mass`), so the matrix it keeps between refreshes goes stale only in its
    small part: a swinging 64-bar chain needs far fewer finite-difference refreshes."""
    nU, nz = U.shape[0], z.shape[0]
    for kk in range(nU + nz):
        qq, vv, aa, zz, zzd = q.copy(), v.copy(), qdd.copy(), z.copy(), zd.copy()
        if kk < nU:
            i = U[kk]
            d = 1e-7 * max(unit[i], abs(q[i]))
            qq[i] += d
            vv[i] += gp * d
            aa[i] += bp * d
        else:
            k = kk - nU
            d = 1e-7 * max(zunit[k], abs(z[k]))
            zz[k] += d
            zzd[k] += cz * d
        M2, rhs2, _, _, C2, _, f2 = terms(qq, vv, zz, factor, kin, mass, K, D, g, w, frc)
        G2 = _residual_rows(M2, rhs2, C2, aa, lam, U)
        for r in range(nU):
            S[r, kk] = (G2[r] - G[r]) / (d * bp)
        for r in range(nz):
            S[nU + r, kk] = ((zzd[r] - f2[r]) - H[r]) / (d * cz)
    for a in range(nU):
        for b in range(nU):
            S[a, b] -= M[U[a], U[b]]


@njit(cache=True)
def march(q, v, qdd, a, lam, z, zd, b, t0, h, qP, vP, aP, factors, work, powers, par, unit,
          zunit, U, P, S, sinfo, kin, mass, K, D, g, w, frc, te, teP, tvP, taP, tfactors,
          rank_rtol, full, rec_q, rec_v, rec_qdd, rec_lam, rec_F, rec_e, rec_res, rec_work,
          rec_z):
    """Steps of size h from t0 while the tables last (qP, vP, aP: (k, p) driver values,
    factors (k, F) force histories at t0 + (j + 1) h), recording the output times te (o,)
    they pass. The state arrays, ``work`` (driver work, dissipated energy) and ``powers``
    (their rates at the state) advance in place.

    An output time between two step ends gets the cubic Hermite interpolant of their
    positions and rates (the elements' states likewise; the work linearly) and, with
    ``full``, the consistent state of :func:`output` there (teP, tvP, taP, tfactors: the
    drivers and force histories at te); without, the interpolated q, v and z only (the
    error estimate's run). Rows go to rec_q, rec_v, rec_qdd (o, n), rec_lam (o, m), rec_F
    (o, p), rec_e (o, 4), rec_res (o,), rec_work (o, 2), rec_z (o, nz).

    Returns (steps done, status of the failed step or 0, the state before the last step
    (q, v, work, z, zd), Newton iterations in all, output rows recorded)."""
    qprev, vprev, wprev, zprev, zdprev = q.copy(), v.copy(), work.copy(), z.copy(), zd.copy()
    iters = 0
    ko = 0
    for j in range(qP.shape[0]):
        st, q1, v1, qdd1, a1, lam1, z1, zd1, b1, it, _, _, pd, pnc = step(
            q, v, qdd, a, lam, z, zd, b, h, qP[j], vP[j], aP[j], factors[j], par, unit, zunit,
            U, P, S, sinfo, kin, mass, K, D, g, w, frc)
        iters += it
        if st != 0:
            return j, st, qprev, vprev, wprev, zprev, zdprev, iters, ko
        qprev[:], vprev[:], wprev[:], zprev[:], zdprev[:] = q, v, work, z, zd
        work[0] += 0.5 * h * (powers[0] + pd)
        work[1] += 0.5 * h * (powers[1] + pnc)
        powers[0], powers[1] = pd, pnc
        q[:], v[:], qdd[:], a[:], lam[:] = q1, v1, qdd1, a1, lam1
        z[:], zd[:], b[:] = z1, zd1, b1
        ta, tb = t0 + j * h, t0 + (j + 1) * h
        same = 1e-10 * max(1.0, abs(tb))  # constrained.same_time
        while ko < te.shape[0] and te[ko] <= tb + same:
            s = 1.0 if abs(te[ko] - tb) <= same else min(max((te[ko] - ta) / h, 0.0), 1.0)
            qo, vo = hermite(qprev, vprev, q, v, h, s)
            zo = hermite(zprev, zdprev, z, zd, h, s)[0]
            rec_work[ko] = (1.0 - s) * wprev + s * work
            rec_z[ko] = zo
            if full:
                qo, vo, qddo, lamo, Fo, eo, reso, _ = output(
                    qo, vo, zo, teP[ko], tvP[ko], taP[ko], tfactors[ko], U, P, rank_rtol,
                    kin, mass, K, D, g, w, frc)
                rec_qdd[ko], rec_lam[ko], rec_F[ko] = qddo, lamo, Fo
                rec_e[ko], rec_res[ko] = eo, reso
            rec_q[ko], rec_v[ko] = qo, vo
            ko += 1
    return qP.shape[0], 0, qprev, vprev, wprev, zprev, zdprev, iters, ko


@njit(cache=True)
def hermite(q0, v0, q1, v1, h, s):
    """Cubic Hermite position and its rate at fraction s in [0, 1] of a step of size h
    (q0, v0, q1, v1: (n,) at its ends)."""
    h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
    h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    d00, d10 = (6 * s ** 2 - 6 * s) / h, 3 * s ** 2 - 4 * s + 1
    d01, d11 = (-6 * s ** 2 + 6 * s) / h, 3 * s ** 2 - 2 * s
    return (h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1,
            d00 * q0 + d10 * v0 + d01 * q1 + d11 * v1)


@njit(cache=True)
def _sub(C, cols):
    out = np.empty((C.shape[0], cols.shape[0]))
    for i in range(C.shape[0]):
        for k in range(cols.shape[0]):
            out[i, k] = C[i, cols[k]]
    return out


@njit(cache=True)
def _svd_parts(CU, rank_rtol):
    """(U_r, U_r^T, s_r, V_r, Z) of C_U = U S V^T at rank r (singular values above
    rank_rtol s_max): V_r U_r^T / s_r is the pseudo-inverse, Z spans the null space."""
    Us, s, Vt = np.linalg.svd(CU)
    rk = 0
    for i in range(s.shape[0]):
        if s[i] > rank_rtol * s[0]:
            rk += 1
    Ur = np.ascontiguousarray(Us[:, :rk])
    return (Ur, np.ascontiguousarray(Ur.T), s[:rk].copy(), np.ascontiguousarray(Vt[:rk].T),
            np.ascontiguousarray(Vt[rk:].T))


@njit(cache=True)
def output(q, v, z, qP, vP, aP, factor, U, P, rank_rtol, kin, mass, K, D, g, w, frc):
    """The consistent state reported at an output time (module ``outputs``): q and v moved
    onto the constraints by least-norm changes of U, the index-1 accelerations and the
    minimum-norm multipliers there (null-space solve on the SVD of C_U), the driver forces
    and the energies (kinetic, gravity, elastic, force elements), the largest closure
    residual (m, rad)."""
    q, v = q.copy(), v.copy()
    for k in range(P.shape[0]):
        q[P[k]] = qP[k]
        v[P[k]] = vP[k]
    m = w.shape[0]
    if m:
        # Newton on the SVD of C_U at the first q (chord steps; refreshed after two): a
        # step end is closed to the step's tolerance and needs one short correction
        A, dA, _, _, r, J, _ = _kinematics(q, v, False, *kin)
        Ur, Urt, sr, Vr, Z = _svd_parts(_sub(w.reshape(-1, 1) * J, U), rank_rtol)
        moved = 0.0
        for it in range(10):
            c = w * r
            if np.max(np.abs(c)) <= 1e-12:
                break
            if it >= 2:
                Ur, Urt, sr, Vr, Z = _svd_parts(_sub(w.reshape(-1, 1) * J, U), rank_rtol)
            dq = Vr @ ((Urt @ c) / sr)
            for k in range(U.shape[0]):
                q[U[k]] -= dq[k]
            moved = max(moved, np.max(np.abs(dq)))
            A, dA, _, _, r, J, _ = _kinematics(q, v, False, *kin)
        C = w.reshape(-1, 1) * J
        if moved > 1e-9:  # the factors at the closed q (else the first q's differ by less)
            Ur, Urt, sr, Vr, Z = _svd_parts(_sub(C, U), rank_rtol)
        CV = C @ v
        if np.max(np.abs(CV)) > 0.0:
            dv = Vr @ ((Urt @ CV) / sr)  # least-norm change of v_U
            for k in range(U.shape[0]):
                v[U[k]] -= dv[k]
    M, rhs, _, c, C, gw, zd, A, dA, r = _terms(q, v, z, factor, kin, mass, K, D, g, w, frc)
    nU = U.shape[0]
    qdd, MUU, f, _, gg = _reduced(M, rhs, C, gw, aP, U, P)
    lam = np.zeros(m)
    if m:
        x = Vr @ ((Urt @ gg) / sr)
        if Z.shape[1]:
            Zt = np.ascontiguousarray(Z.T)
            y = np.linalg.solve(Zt @ MUU @ Z, Zt @ (f - MUU @ x))
            x = x + Z @ y
        lam = Ur @ ((np.ascontiguousarray(Vr.T) @ (f - MUU @ x)) / sr)
    else:
        x = np.linalg.solve(MUU, f)
    for a in range(nU):
        qdd[U[a]] = x[a]
    FP = _residual_rows(M, rhs, C, qdd, lam, P)
    e = np.empty(4)
    e[0] = 0.5 * v @ (M @ v)
    e[1] = gravity_potential(q, A, g, mass)
    e[2] = 0.5 * q @ (K @ q)
    e[3] = potential(q, A, dA, frc)
    res = 0.0
    for i in range(m):
        res = max(res, abs(r[i]))
    return q, v, qdd, lam, FP, e, res, zd


@njit(cache=True)
def start(q, v, z, aP, factor, U, P, eps, kin, mass, K, D, g, w, frc):
    """(q'' (n,), lambda (m,), z' (nz,), driver power, -dissipated power) at a consistent
    (q, v) and the elements' states z: the start of a run with element states (the
    regularised, refined index-1 solve)."""
    M, rhs, Qnc, _, C, gw, zd = terms(q, v, z, factor, kin, mass, K, D, g, w, frc)
    qdd, lam = _index1(M, rhs, C, gw, aP, U, P, eps)
    pd, pnc = _powers(M, rhs, Qnc, C, gw, v, aP, U, P, eps)
    return qdd, lam, zd, pd, pnc


@njit(cache=True)
def index1_rhs(q, v, aP, factor, U, P, eps, kin, mass, K, D, g, w, frc):
    """(q''_U, driver power, -dissipated power) of the index-1 form at (q, v) (drivers
    already set; no element states): M q'' + C^T lambda = rhs, C q'' = gamma by the
    regularised, refined saddle-point solve (constrained.ConstrainedSystem.accelerations
    with eps)."""
    M, rhs, Qnc, _, C, gw, _ = terms(q, v, np.zeros(0), factor, kin, mass, K, D, g, w, frc)
    qdd, lam = _index1(M, rhs, C, gw, aP, U, P, eps)
    pd = 0.0
    if P.shape[0]:
        FP = _residual_rows(M, rhs, C, qdd, lam, P)
        for k in range(P.shape[0]):
            pd += FP[k] * v[P[k]]
    x = np.empty(U.shape[0])
    for a in range(U.shape[0]):
        x[a] = qdd[U[a]]
    return x, pd, -(Qnc @ v)
