"""The numpy oracle of the compiled index-3 generalised-alpha step
(:mod:`pipeline.solver.dae_kernels`): the same iteration written with the numpy equations of
:class:`~pipeline.solver.constrained.ConstrainedSystem` (method: :mod:`pipeline.solver.index3`).
``test_compiled_step.py`` requires the two to agree step for step. It has no element
states."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from pipeline.solver.constrained import ConstrainedSystem
from pipeline.solver.dae_kernels import MAX_NEWTON, REFRESH_AFTER
from pipeline.solver.generalized_alpha import NEWTON_SHARE, coefficients
from pipeline.solver.index3 import StepOutcome, StepState, powers


class Index3Stepper:
    """Steps of the index-3 generalised-alpha method (module docstring).

    Parameters: those of :class:`pipeline.solver.index3_compiled.CompiledStepper`
    (without ``data``).
    """

    MAX_NEWTON = MAX_NEWTON
    REFRESH_AFTER = REFRESH_AFTER

    def __init__(self, cs: ConstrainedSystem, rho_inf: float = 0.8, newton_rtol: float = 1e-8,
                 newton_atol: float = 1e-10, closure_tol: float = 1e-10, unit=None,
                 jump: float = 0.1, eps: float = 1e-10):
        self.cs = cs
        self.am, self.af, self.beta, self.gamma = coefficients(rho_inf)
        self.rtol, self.atol = float(newton_rtol), float(newton_atol)
        self.closure_tol = float(closure_tol)
        self.unit = np.ones(cs.n) if unit is None else np.asarray(unit, dtype=float)
        self.jump = float(jump)
        self.eps = float(eps)
        self.S = None  # (h, S (nU, nU)) scaled dynamic block
        self.stale = False
        self.evaluations = 0
        self.jacobians = 0

    # ------------------------------------------------------------------ start
    def start(self, t: float, q: np.ndarray, v: np.ndarray) -> StepState:
        """Consistent accelerations and multipliers at a consistent (q, v) (index-1 solve)."""
        cs = self.cs
        st = cs.evaluate(t, q, v)
        self.evaluations += 1
        qdd, lam = cs.accelerations(st)
        return StepState(t, q.copy(), v.copy(), qdd, qdd.copy(), lam, powers(cs, st, v))

    # ------------------------------------------------------------------ pieces
    def _coeffs(self, h):
        bp = (1.0 - self.am) / (self.beta * h * h * (1.0 - self.af))
        gp = self.gamma / (self.beta * h)
        return bp, gp

    def _G(self, t1, q, v, qdd, lam):
        st = self.cs.evaluate(t1, q, v)
        self.evaluations += 1
        return st, self.cs.residual(st, qdd, lam)[self.cs.U]

    def _fd_block(self, t1, q, v, qdd, lam, G0, bp, gp, M_UU):
        """(dG/dq_U along the Newton direction) / beta' - M_UU, (nU, nU), by forward
        differences (M_UU: the mass matrix's U block at q)."""
        U = self.cs.U
        S = np.empty((U.size, U.size))
        for k, i in enumerate(U):
            d = 1e-7 * max(self.unit[i], abs(q[i]))
            qq, vv, aa = q.copy(), v.copy(), qdd.copy()
            qq[i] += d
            vv[i] += gp * d
            aa[i] += bp * d
            S[:, k] = (self._G(t1, qq, vv, aa, lam)[1] - G0) / (d * bp)
        self.jacobians += 1
        return S - M_UU  # the kept remainder: the current M_UU is added at each iteration

    def _mass_scale(self, S):
        d = np.abs(np.diag(S))
        return float(d.max()) if d.size and d.max() > 0 else 1.0

    # ------------------------------------------------------------------ step
    def step(self, s0: StepState, h: float) -> StepOutcome:
        """Attempt one step of size h from the accepted state s0."""
        cs, U = self.cs, self.cs.U
        am, af, beta, gamma = self.am, self.af, self.beta, self.gamma
        bp, gp = self._coeffs(h)
        t1 = s0.t + h
        qP, vP, aP = cs.drive(t1)
        qdd = s0.qdd.copy()
        qdd[cs.P] = aP
        a1 = (af * s0.qdd - am * s0.a + (1.0 - af) * qdd) / (1.0 - am)
        q = s0.q + h * s0.v + h * h * ((0.5 - beta) * s0.a + beta * a1)
        v = s0.v + h * ((1.0 - gamma) * s0.a + gamma * a1)
        q[cs.P], v[cs.P] = qP, vP
        q_pred = q.copy()
        lam = s0.lam.copy()
        m, nU = cs.m, U.size
        tol = self.atol * self.unit[U] + self.rtol * np.abs(q[U])
        refreshed = False
        st = None
        closure_err = np.inf
        prev = 0.0
        factors = None
        for it in range(self.MAX_NEWTON):
            try:
                st, G = self._G(t1, q, v, qdd, lam)
            except (ArithmeticError, ValueError, np.linalg.LinAlgError):
                return StepOutcome(None, it, "evaluation")
            if not (np.all(np.isfinite(G)) and np.all(np.isfinite(st.c))):
                return StepOutcome(None, it, "evaluation")
            closure_err = float(np.abs(st.c).max()) if m else 0.0
            if self.S is None or not 0.5 <= h / self.S[0] <= 2.0 or self.stale \
                    or (it == self.REFRESH_AFTER and not refreshed):
                self.S = (h, self._fd_block(t1, q, v, qdd, lam, G, bp, gp, st.terms.M[np.ix_(U, U)]))
                refreshed, self.stale = True, False
                factors = None
            if factors is None:  # factored once a step and again after a refresh
                S = self.S[1] + st.terms.M[np.ix_(U, U)]
                s = self._mass_scale(S)
                K = np.zeros((nU + m, nU + m))
                K[:nU, :nU] = S
                if m:
                    CU = st.C[:, U]
                    K[:nU, nU:] = s * CU.T
                    K[nU:, :nU] = s * CU
                    K[nU:, nU:] = -self.eps * s * np.eye(m)
                try:
                    factors = sla.lu_factor(K, check_finite=False)
                except (ValueError, np.linalg.LinAlgError):
                    return StepOutcome(None, it, "newton")
            rhs = np.concatenate([-G / bp, -s * st.c])
            x = sla.lu_solve(factors, rhs, check_finite=False)
            if not np.all(np.isfinite(x)):
                return StepOutcome(None, it, "newton")
            dq = x[:nU]
            q[U] += dq
            v[U] += gp * dq
            qdd[U] += bp * dq
            if m:
                lam = lam + bp * s * x[nU:]
            moved = float(np.abs((q[U] - q_pred[U]) / self.unit[U]).max(initial=0.0))
            if moved > self.jump:
                return StepOutcome(None, it + 1, "jump", moved, closure_err)
            # the error left after this correction: |dq| theta / (1 - theta) for a contraction
            # theta (a modified Newton converges linearly: a small correction alone does not
            # mean a small error), judged against tol
            # ... and against NEWTON_SHARE of the step's local error estimate: Newton errors
            # accumulate over the steps, truncation errors of O(h^3) per step do too, and the
            # former must stay below the latter for the method to keep its order as h -> 0
            e_loc = np.abs((beta - 1.0 / 6.0) * h * h * (qdd - s0.qdd)[U])
            floor = 1e-14 * (np.abs(q[U]) + self.unit[U])
            tol_it = np.minimum(tol, np.maximum(NEWTON_SHARE * e_loc, floor))
            norm = float(np.abs(dq / tol_it).max(initial=0.0))
            theta = norm / prev if prev else 0.0
            if theta >= 1.0 and it >= 2 and not refreshed:
                self.stale = True  # refresh the matrix at the next iteration
            left = norm * theta / (1.0 - theta) if 0.0 < theta < 1.0 else norm
            prev = norm
            # the user's tolerance alone once the tight one costs more than a few iterations
            # (a near-singular direction converges slowly and needs no more)
            enough = it >= self.REFRESH_AFTER and float(np.abs(dq / tol).max(initial=0.0)) <= 1
            if (left <= 1.0 or norm <= 1e-3 or enough) and closure_err <= self.closure_tol:
                if it >= self.REFRESH_AFTER:
                    self.stale = True
                a_new = a1 + (1.0 - af) / (1.0 - am) * (qdd - s0.qdd)
                a_new[cs.P] = aP
                # st: the last evaluation, a correction below the Newton tolerance away
                return StepOutcome(StepState(t1, q, v, qdd, a_new, lam, powers(cs, st, v)),
                                   it + 1, "", moved, closure_err)
        self.stale = True
        return StepOutcome(None, self.MAX_NEWTON, "newton", 0.0, closure_err)

    def reset(self):
        """Forget the iteration matrix (after a failed step)."""
        self.S = None

    def memory(self):
        """A copy of what the next step reuses (the iteration matrix; :meth:`recall`)."""
        return (None if self.S is None else (self.S[0], self.S[1].copy())), self.stale

    def recall(self, memory) -> None:
        """Reuse ``memory`` (from :meth:`memory`): the steps then repeat bit for bit."""
        S, self.stale = memory
        self.S = None if S is None else (S[0], S[1].copy())
