"""The equations of a closed-loop system as a DAE over all coordinates (DESIGN §4 (b)).

    M(q) q'' - rhs(q, q', t) + C(q)^T lambda = 0,      c(q, t) = 0,

with q every joint and modal coordinate, the driven coordinates eliminated (they are known
functions of time, q_P = d(t)), c = w * Phi the loop-closure rows made dimensionless by the
row weights w (1/length scale on positions, 1 on rotations), C = dc/dq_U its Jacobian in the
other coordinates U and lambda the multipliers of those rows (N m per unit row, i.e. the
generalized constraint forces are C^T lambda). Every closure row is kept: redundant rows
(planar loops built in 3D, a parallelogram's shared bar) make C rank-deficient and the
multipliers non-unique; the solves here then return the minimum-norm multipliers.

:class:`ConstrainedSystem` evaluates the terms at a state and offers the projections the
integrator and its outputs need: positions and velocities onto the constraints (least
squares, only U moves) and the accelerations and multipliers of a state (the index-1 system).
The driver forces are F_P = (M q'' - rhs + C_full^T lambda)_P, the generalized forces the
drivers apply along their coordinates (a cylinder's force, a motor's torque).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from pipeline.dynamics.equations import EquationTerms, equation_terms
from pipeline.dynamics.partition import driver_state
from pipeline.kinematics.closure import closure
from pipeline.kinematics.partition import RANK_RTOL

__all__ = ["REGULARISATION", "ConstrainedState", "ConstrainedSystem", "drivers_at", "least_norm",
           "mass_scale", "saddle_solve", "saddle_solve_regularised", "same_time"]

#: regularisation of the saddle-point solves of integrators (see
#: :func:`saddle_solve_regularised`): relaxes only constraint directions whose singular value
#: of the dimensionless Jacobian is below about 1e-4
REGULARISATION = 1e-8


@dataclass(frozen=True)
class ConstrainedState:
    """Terms of the DAE at one state (q, q', t).

    q, qd : (n,); c : (m,) weighted closure residual; C : (m, n) its Jacobian in every
    coordinate (the U columns enter the DAE, the P columns the driver forces); gamma :
    (m,) weighted right-hand side of C q'' = gamma; terms : the equations of motion.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    c: np.ndarray
    C: np.ndarray
    gamma: np.ndarray
    terms: EquationTerms


class ConstrainedSystem:
    """A :class:`pipeline.dynamics.System` seen as the DAE above.

    Attributes
    ----------
    system : the System.  U : (nU,) indices of the integrated coordinates; P : (p,) driven.
    m : number of closure rows (6 per loop).  w : (m,) row weights.
    """

    def __init__(self, system):
        self.system = system
        mech = system.mechanism
        names = list(system.drivers)
        self.P = mech.indices(names) if names else np.zeros(0, dtype=int)
        self.U = np.setdiff1d(np.arange(mech.n), self.P)
        self.drivers = tuple(system.drivers[k] for k in names)
        self.m = 6 * len(mech.topology.loops)
        self.w = np.asarray(mech.row_weights, dtype=float)
        self.n = mech.n
        #: a break (s) at which :meth:`drive` gives the rates and accelerations just before
        #: it: set by a run while it steps up to that break
        self.left_of: float | None = None

    # ------------------------------------------------------------------ drivers
    def drive(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(values, rates, accelerations), each (p,), of the drivers at t (s); at the break
        ``left_of`` (when set) the rates and accelerations just before it."""
        return drivers_at(self, t, self.left_of)

    def drive_table(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(values, rates, accelerations), each (k, p), of the drivers at the times (k,) s
        (one vectorised call per driver)."""
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.empty((3, times.size, self.P.size))
        if times.size <= 4:  # a few times: the scalar evaluations are cheaper
            for k, t in enumerate(times):
                out[:, k, :] = np.reshape(self.drive(float(t)), (3, self.P.size))
            return out[0], out[1], out[2]
        at = times
        if self.left_of is not None:
            at = np.where(np.abs(times - self.left_of) <= same_time(times), _before(times),
                          times)
        for j, d in enumerate(self.drivers):
            out[0, :, j], out[1, :, j], out[2, :, j] = d.value(times), d.rate(at), d.accel(at)
        return out[0], out[1], out[2]

    def with_drivers(self, t: float, q, qd=None, qdd=None):
        """Copies of q (and qd, qdd) with the driven entries set to the drivers at t."""
        d = self.drive(t)
        out = []
        for x, k in ((q, 0), (qd, 1), (qdd, 2)):
            if x is None:
                continue
            x = np.array(x, dtype=float)
            x[self.P] = d[k]
            out.append(x)
        return tuple(out)

    def breaks(self, t0: float, t1: float) -> np.ndarray:
        """The drivers' break times (:meth:`pipeline.kinematics.driver_base.Driver.breaks`)
        in (t0, t1], sorted, s; one within 1e-10 (relative) of t0 is left out (it is the
        start)."""
        tol = float(same_time(t0))
        times = {t for d in self.drivers for t in d.breaks() if t0 + tol < t <= t1 + tol}
        return np.array(sorted(times), dtype=float)

    def next_break(self, t: float, t1: float) -> float | None:
        """The drivers' first break after t (s) and at most t1, or None: where a run
        stepping from t stops and starts afresh, with ``left_of`` set to it meanwhile."""
        b = self.breaks(t, t1)
        return float(b[0]) if b.size else None

    def across_break(self, t: float, q: np.ndarray, v: np.ndarray, before=None
                     ) -> tuple[np.ndarray, float]:
        """(v (n,) just after a break of the drivers at t, the drivers' work there, J).

        The driven rates jump from their values just before t to those at t. An ideal
        prescribed motion does that by an impulse: the other velocities take the jump
        that keeps the momentum along every motion the drivers and the loops leave free,
        M_UU dv_U + M_UP dv_P + C_U^T Lambda = 0 and C dv = 0 (Lambda: the loops' impulses,
        minimum-norm where rows are redundant). Positions do not move during an impulse,
        so the drivers' work is the change of kinetic energy. Where no rate jumps, v is
        returned with its driven entries set, and no work. ``before``: the driven rates
        before t (p,) if not the drivers' own just before t."""
        v = np.array(v, dtype=float)
        after = driver_state(self, t)[1]
        before = driver_state(self, _before(t))[1] if before is None else np.asarray(before)
        dvP = after - before
        v[self.P] = after
        if not dvP.size or not np.any(np.abs(dvP) > 1e-12 * np.maximum(1.0, np.abs(after))):
            return v, 0.0
        v[self.P] = before
        st = self.evaluate(t, q, v)
        M, U, P = st.terms.M, self.U, self.P
        f = -M[np.ix_(U, P)] @ dvP
        if self.m:
            dvU, _ = saddle_solve(M[np.ix_(U, U)], st.C[:, U], f, -st.C[:, P] @ dvP)
        else:
            dvU = np.linalg.solve(M[np.ix_(U, U)], f)
        kinetic = 0.5 * v @ M @ v
        v[U] += dvU
        v[P] = after
        return v, float(0.5 * v @ M @ v - kinetic)

    # ------------------------------------------------------------------ terms
    def evaluate(self, t: float, q: np.ndarray, qd: np.ndarray) -> ConstrainedState:
        """All terms at (q, qd, t) (q, qd full, drivers already set)."""
        mech = self.system.mechanism
        cv = closure(mech, q, qd)
        terms = equation_terms(self.system, q, qd, t, tree=cv.tree)
        w = self.w
        if self.m:
            return ConstrainedState(t, q, qd, w * cv.r, w[:, None] * cv.J, w * cv.gamma, terms)
        return ConstrainedState(t, q, qd, np.zeros(0), np.zeros((0, self.n)), np.zeros(0), terms)

    def residual(self, st: ConstrainedState, qdd: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """(n,) M q'' - rhs + C^T lambda (its U entries vanish on a solution)."""
        r = st.terms.M @ qdd - st.terms.rhs
        if self.m:
            r = r + st.C.T @ lam
        return r

    def driver_forces(self, st: ConstrainedState, qdd: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """(p,) generalized force each driver applies along its coordinate, N or N m."""
        return self.residual(st, qdd, lam)[self.P]

    # ------------------------------------------------------------------ index-1 solve
    def accelerations(self, st: ConstrainedState, eps: float | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
        """(q'' (n,), lambda (m,)) of the state: M q'' + C^T lambda = rhs and C q'' = gamma
        on U, q''_P from the drivers; minimum-norm multipliers when rows are redundant.

        ``eps``: solve the regularised system instead (:func:`saddle_solve_regularised`),
        smooth through singular positions (an integrator's right-hand side); None: the exact
        null-space solve with the minimum-norm multipliers (outputs)."""
        U, P = self.U, self.P
        qdd = np.zeros(self.n)
        qdd[P] = self.drive(st.t)[2]
        M = st.terms.M
        f = st.terms.rhs[U] - M[np.ix_(U, P)] @ qdd[P]
        if not self.m:
            qdd[U] = np.linalg.solve(M[np.ix_(U, U)], f)
            return qdd, np.zeros(0)
        CU = st.C[:, U]
        g = st.gamma - st.C[:, P] @ qdd[P]
        if eps is None:
            x, lam = saddle_solve(M[np.ix_(U, U)], CU, f, g)
        else:
            x, lam = saddle_solve_regularised(M[np.ix_(U, U)], CU, f, g, eps)
        qdd[U] = x
        return qdd, lam

    # ------------------------------------------------------------------ projections
    def project_positions(self, t: float, q: np.ndarray, tol: float = 1e-12,
                          max_iter: int = 8) -> np.ndarray:
        """q (n,) moved onto c(q, t) = 0 by the least-norm change of its U entries
        (Gauss-Newton, a few iterations from a nearby q); driven entries from the drivers."""
        (q,) = self.with_drivers(t, q)
        if not self.m:
            return q
        mech = self.system.mechanism
        for _ in range(max_iter):
            cv = closure(mech, q)
            c = self.w * cv.r
            if np.abs(c).max() <= tol:
                break
            q[self.U] -= least_norm(self.w[:, None] * cv.J[:, self.U], c)
        return q

    def project_velocities(self, st: ConstrainedState, qd: np.ndarray) -> np.ndarray:
        """qd (n,) with the U entries moved by the least-norm change onto C qd = 0 (the
        driven entries are the drivers' rates)."""
        if not self.m:
            return qd
        qd = np.array(qd, dtype=float)
        qd[self.U] -= least_norm(st.C[:, self.U], st.C @ qd)
        return qd


def same_time(t):
    """Tolerance (s) within which two times are the same instant (an output, a break)."""
    return 1e-10 * np.maximum(1.0, np.abs(t))


def drivers_at(part, t: float, left_of: float | None = None):
    """(values, rates, accelerations), each (p,), of ``part.drivers`` at t (s); at the
    break ``left_of`` the rates and accelerations just before it (a run stepping up to a
    break sees the motion that arrives there, ConstrainedSystem.across_break the jump)."""
    d = driver_state(part, t)
    if left_of is not None and abs(t - left_of) <= same_time(t):
        before = driver_state(part, _before(t))
        return d[0], before[1], before[2]
    return d


def _before(t):
    """A time just before t, closer than any table's knots: rates there are the limits
    from the left."""
    return t - 1e-9 * np.maximum(1.0, np.abs(t))


def least_norm(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Minimum-norm least-squares x of A x = b (rank decided at RANK_RTOL)."""
    return np.linalg.lstsq(A, b, rcond=RANK_RTOL)[0]


def mass_scale(M: np.ndarray) -> float:
    """Largest diagonal entry of M (1 for an empty or massless M): scales the constraint
    blocks of the saddle-point matrices to the dynamic block."""
    d = np.abs(np.diag(M))
    return float(d.max()) if d.size and d.max() > 0 else 1.0


def saddle_solve_regularised(M: np.ndarray, C: np.ndarray, f: np.ndarray, g: np.ndarray,
                             eps: float, refine: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """(x, lambda) of M x + C^T lambda = f, C x = g, regular even where C is rank-deficient.

    The matrix factored is the regularised [[M, s C^T], [s C, -eps s I]] (s =
    ``mass_scale(M)``); ``refine`` steps of iterative refinement against the exact system
    then recover the exact solution in every constraint direction whose singular value
    sigma (of the dimensionless C) has sigma^2 >> eps (the error shrinks by eps / sigma^2 per
    step), while the directions that are (nearly) lost at a singular position or redundant
    are relaxed smoothly instead of cut off: no jump of the accelerations where a rank
    decision would flip, no 1 / sigma blow-up of the drift terms there.
    """
    s = mass_scale(M)
    k, m = M.shape[0], C.shape[0]
    K = np.empty((k + m, k + m))
    K[:k, :k] = M
    K[:k, k:] = s * C.T
    K[k:, :k] = s * C
    K[k:, k:] = -eps * s * np.eye(m)
    b = np.concatenate([f, s * g])
    lu = sla.lu_factor(K, check_finite=False)
    z = sla.lu_solve(lu, b, check_finite=False)
    for _ in range(refine):
        r = b - K @ z
        r[k:] -= eps * s * z[k:]  # the exact system has no (2, 2) block
        z = z + sla.lu_solve(lu, r, check_finite=False)
    return z[:k], s * z[k:]


def saddle_solve(M: np.ndarray, C: np.ndarray, f: np.ndarray, g: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(x, lambda) of M x + C^T lambda = f, C x = g with C possibly rank-deficient:
    x unique (M positive definite on the null space of C), lambda the minimum-norm one.

    Null-space method on an orthonormal basis of C's row space (SVD): x = x_r + Z y with
    C x_r = g (least norm) and Z spanning null(C); then Z^T M Z y = Z^T (f - M x_r) and
    lambda from C^T lambda = f - M x in the least-squares sense.
    """
    U_, s, Vt = np.linalg.svd(C, full_matrices=True)
    r = int(np.sum(s > RANK_RTOL * s[0])) if s.size and s[0] > 0 else 0
    V_r, Z = Vt[:r].T, Vt[r:].T
    x = V_r @ ((U_[:, :r].T @ g) / s[:r])
    if Z.shape[1]:
        y = np.linalg.solve(Z.T @ M @ Z, Z.T @ (f - M @ x))
        x = x + Z @ y
    lam = U_[:, :r] @ ((V_r.T @ (f - M @ x)) / s[:r])
    return x, lam
