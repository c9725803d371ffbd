"""Generalised-alpha integrator (Chung & Hulbert 1993, in the Arnold & Bruls 2007 form for
nonlinear second-order ODEs) as a scipy ``OdeSolver``.

Why: closed loops with flexible links have closed-loop modes near 1 kHz that nobody needs
resolved, yet they cap an explicit method's step (DOP853 on the loader: h w_max ~ 4.9).
Generalised-alpha is second-order accurate, unconditionally stable for linear problems
and damps the highest modes with the user's spectral radius rho_inf, so the step follows
the motion of interest. The state is y = [q_I, v_I, extra...] where ``fun`` returns
[v_I, a_I, extra'] (the solver's reduced equations); the extra integrals (driver work,
dissipated energy) use the trapezoidal rule.

Each step solves r(a) = a - f(t + h, q(a), v(a)) = 0 for the new acceleration by Newton's
method with the iteration matrix S = I - beta' df/dq - gamma' df/dv; df/dq and df/dv are
finite differences, kept across steps and refreshed only when Newton slows down or fails;
between refreshes Broyden's secant update keeps S current at no extra evaluation.
Convergence is judged by what the residual still does to the step (the q and v changes
beta' r and gamma' r against atol + rtol |y|), so that the tolerances mean what they mean
for scipy's solvers.
A step whose Newton fails after a refresh (or whose trial state the loops cannot reach:
``fun`` returns NaN) is retried with half the step, down to 1e-6 of the user's step.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import DenseOutput, OdeSolver

from pipeline.core.errors import ConfigError

#: a fixed step's Newton iterations stop where the error left in q is below this share of
#: the step's local truncation error estimate |(beta - 1/6) h^2 (q''_1 - q''_0)|. Newton
#: errors in q reach the accelerations divided by beta h^2 and add up over the steps; at 1 %
#: a fast-spinning top stopped converging as h fell (heavy top over 1 s at h = 0.125 ms:
#: 2.5e-4 off an independent rigid-body integration, 3.0e-6 at 1e-4 of it, second order
#: again, for 10 % more evaluations)
NEWTON_SHARE = 1e-4

#: a step that has not converged after this many modified-Newton iterations refreshes its
#: iteration matrix before the next (both generalised-alpha steps: the partitioned ODE form
#: here, and the index-3 step of pipeline.solver.dae_kernels). Loader, 100 steps of 5 ms
#: (partitioned): 2 -> 1360 evaluations, 3 -> 744, 4 -> 562, only on failure (8) -> 615; a
#: swinging 64-bar chain (index-3) refreshed it 33 times a second after 3 for steps that a
#: fourth cheap iteration finishes (5.0 evaluations a step against 3.0)
REFRESH_AFTER = 4


def coefficients(rho_inf: float) -> tuple[float, float, float, float]:
    """(alpha_m, alpha_f, beta, gamma) for spectral radius ``rho_inf`` in [0, 1] at h w -> inf.

    Examples
    --------
    >>> coefficients(1.0)
    (0.5, 0.5, 0.25, 0.5)
    """
    if not 0.0 <= rho_inf <= 1.0:
        raise ConfigError(f"rho_inf: expected a value in [0, 1], got {rho_inf}")
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gamma = 0.5 + af - am
    beta = 0.25 * (gamma + 0.5) ** 2
    return am, af, beta, gamma


def first_order_coefficients(rho_inf: float) -> tuple[float, float]:
    """(alpha_m, gamma) of first-order generalised-alpha (Jansen, Whiting & Hulbert 2000)
    in the convention of :func:`coefficients` ((1 - alpha_m) b_{n+1} + alpha_m b_n =
    (1 - alpha_f) z'_{n+1} + alpha_f z'_n, z_{n+1} = z_n + h ((1 - gamma) b_n + gamma
    b_{n+1}), alpha_f the second-order method's): second order, and both roots at
    -rho_inf where h lambda -> -inf, for states stepped with the motion (an element's own
    states, such as hydraulic pressures).

    Examples
    --------
    >>> first_order_coefficients(1.0)
    (0.5, 0.5)
    """
    af = coefficients(rho_inf)[1]
    amz = (3.0 * rho_inf - 1.0) / (2.0 * (rho_inf + 1.0))
    return amz, 0.5 + af - amz


class GeneralizedAlpha(OdeSolver):
    """Fixed-step generalised-alpha for y = [q (k), v (k), extras (e)] with
    fun(t, y) = [v, a(t, q, v), extras'] (see the module docstring).

    Parameters
    ----------
    fun, t0, y0, t_bound : as scipy's OdeSolver.
    n_second : k, the number of second-order coordinates (q) in y.
    step : fixed step h, s (the last one is shortened to land on t_bound).
    rho_inf : spectral radius at infinite frequency (1: no numerical damping; 0.8 default).
    rtol, atol : Newton tolerance: the changes of q and v the acceleration residual would still
        cause must be below atol + rtol |q| and atol + rtol |v| (per coordinate).
    max_step : caps the step (a run that rejected a step as leaving the loops' branch retries
        with a shorter one); ``first_step`` and other options are ignored.
    """

    MAX_NEWTON = 8
    #: Newton iterations after which a step refreshes df/dq, df/dv (module's REFRESH_AFTER)
    REFRESH_AFTER = REFRESH_AFTER
    #: ... and at the start of the step after one whose last Newton iteration contracted the
    #: residual by less than this factor (loader, 10 s at 10 ms: 3.30 -> 2.94 evaluations per
    #: step with 0.03; 0.01: 3.05, 0.1: 2.98)
    THETA_REFRESH = 0.03
    #: the driver passes n_second (the reduced coordinates' count) and the fixed-step options
    SECOND_ORDER = True

    def __init__(self, fun, t0, y0, t_bound, *, n_second: int, step: float, rho_inf: float = 0.8,
                 rtol: float = 1e-8, atol: float = 1e-10, max_step=np.inf, **_):
        super().__init__(fun, t0, y0, t_bound, vectorized=False)
        if not (step and np.isfinite(step) and step > 0):
            raise ConfigError(f"generalized_alpha: step: expected a time step > 0 s, got {step}")
        self.k = int(n_second)
        self.t_start = float(t0)
        self.h = float(min(step, max_step))
        self.am, self.af, self.beta, self.gamma = coefficients(rho_inf)
        self.rtol, self.atol = float(rtol), float(atol)
        self.f = np.asarray(self.fun(self.t, self.y), dtype=float)
        if not np.all(np.isfinite(self.f)):
            raise ConfigError("generalized_alpha: the start state cannot be evaluated")
        self.abar = self.f[self.k:2 * self.k].copy()  # acceleration-like variable
        self.J = None  # (df/dq, df/dv) at some recent state
        self._stale = False  # refresh J at the next step
        self.S = None  # (h, iteration matrix dr/da for steps of size h)
        self.jac_updates = 0
        self.newton_iterations = 0
        self._old = None

    # ------------------------------------------------------------------ pieces
    def _state(self, a_new, h):
        k, y = self.k, self.y
        abar_new = ((1 - self.af) * a_new + self.af * self.f[k:2 * k]
                    - self.am * self.abar) / (1 - self.am)
        q = y[:k] + h * y[k:2 * k] + h * h * ((0.5 - self.beta) * self.abar + self.beta * abar_new)
        v = y[k:2 * k] + h * ((1 - self.gamma) * self.abar + self.gamma * abar_new)
        return q, v, abar_new

    def _converged(self, r, q, v, bq, bv) -> bool:
        """Is the acceleration residual r (k,) small enough? Judged by what it does to the
        step: the position and velocity changes it would still cause (bq r, bv r) must be
        below atol + rtol |y| per coordinate, as scipy's solvers judge their error."""
        r = np.abs(r)
        return bool((bq * r <= self.atol + self.rtol * np.abs(q)).all()
                    and (bv * r <= self.atol + self.rtol * np.abs(v)).all())

    def _eval(self, t, q, v, extras):
        return np.asarray(self.fun(t, np.concatenate([q, v, extras])), dtype=float)

    def _jacobian(self, t, q, v, extras, f0):
        """Forward differences of a(t, q, v) in q and v, (k, k) each."""
        k = self.k
        Jq, Jv = np.empty((k, k)), np.empty((k, k))
        for J, base, which in ((Jq, q, 0), (Jv, v, 1)):
            for i in range(k):
                d = 1e-7 * max(1.0, abs(base[i]))
                x = base.copy()
                x[i] += d
                f = self._eval(t, x, v, extras) if which == 0 else self._eval(t, q, x, extras)
                J[:, i] = (f[k:2 * k] - f0[k:2 * k]) / d
        self.jac_updates += 1
        return Jq, Jv

    def _try(self, h):
        """One step of size h; returns (converged, y_new, f_new, abar_new)."""
        k, t1 = self.k, self.t + h
        bq = h * h * self.beta * (1 - self.af) / (1 - self.am)
        bv = h * self.gamma * (1 - self.af) / (1 - self.am)
        a = self.f[k:2 * k].copy()
        extras_old = self.y[2 * k:]
        refreshed = False
        prev = None  # (a, r) of the previous iteration, for the secant update
        for it in range(3 * self.MAX_NEWTON):
            q, v, abar_new = self._state(a, h)
            extras = extras_old + 0.5 * h * self.f[2 * k:]  # predictor; corrected below
            f = self._eval(t1, q, v, extras)
            self.newton_iterations += 1
            if not np.all(np.isfinite(f)):
                return False, None, None, None
            r = a - f[k:2 * k]
            if self._converged(r, q, v, bq, bv):
                if prev is not None and it >= 2:  # slow contraction: refresh at the next step
                    theta = np.abs(r).max() / max(np.abs(prev[1]).max(), 1e-300)
                    self._stale = theta > self.THETA_REFRESH
                extras = extras_old + 0.5 * h * (self.f[2 * k:] + f[2 * k:])
                f[:k] = v
                return True, np.concatenate([q, v, extras]), f, abar_new
            # slow convergence means the iteration matrix is stale: refresh it once
            if self.J is None or (it == self.REFRESH_AFTER and not refreshed) \
                    or (it == 0 and self._stale):
                self.J = self._jacobian(t1, q, v, extras, f)
                self.S, refreshed, self._stale = None, True, False
            elif it >= 2 * self.MAX_NEWTON:
                return False, None, None, None
            if self.S is None or self.S[0] != h:
                self.S = (h, np.eye(k) - bq * self.J[0] - bv * self.J[1])
            elif prev is not None:
                # Broyden's update: the iteration matrix learns dr/da from the iterates
                # already paid for (no extra evaluation), and keeps it for later steps
                da, dr = a - prev[0], r - prev[1]
                dd = float(da @ da)
                if dd > 0.0:
                    S = self.S[1]
                    self.S = (h, S + np.outer(dr - S @ da, da / dd))
            prev = (a, r)
            try:
                a = a - np.linalg.solve(self.S[1], r)
            except np.linalg.LinAlgError:
                return False, None, None, None
        return False, None, None, None

    # ------------------------------------------------------------------ OdeSolver API
    def _step_impl(self):
        h = min(self.h, self.t_bound - self.t)
        while True:
            ok, y_new, f_new, abar_new = self._try(h)
            if ok:
                break
            self.J = self.S = None  # a stale iteration matrix is the usual culprit
            h *= 0.5
            if h < 1e-6 * self.h:
                return False, (f"generalized_alpha: Newton failed down to step {h:.3g} s at "
                               f"t = {self.t:.6g} s")
        self._old = (self.t, self.y, self.f)
        self.t, self.y, self.f, self.abar = self._grid(self.t + h), y_new, f_new, abar_new
        return True, None

    def _grid(self, t: float) -> float:
        """t snapped to t0 + k h when within rounding of it (no drift over many steps,
        so steps land on an output grid spaced by multiples of h)."""
        k = round((t - self.t_start) / self.h)
        tk = self.t_start + k * self.h
        return min(tk, self.t_bound) if abs(t - tk) <= 1e-9 * self.h else t

    def _dense_output_impl(self):
        t0, y0, f0 = self._old
        return _Hermite(t0, self.t, y0, self.y, f0, self.f)


class _Hermite(DenseOutput):
    """Cubic Hermite interpolation of y with its derivatives at both ends."""

    def __init__(self, t0, t1, y0, y1, f0, f1):
        super().__init__(t0, t1)
        self.y0, self.y1, self.f0, self.f1, self.h = y0, y1, f0, f1, t1 - t0

    def _call_impl(self, t):
        s = (np.asarray(t) - self.t_old) / self.h
        h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
        h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        y = (np.multiply.outer(self.y0, h00) + np.multiply.outer(self.f0, self.h * h10)
             + np.multiply.outer(self.y1, h01) + np.multiply.outer(self.f1, self.h * h11))
        return y
