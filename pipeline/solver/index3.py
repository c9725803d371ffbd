"""Index-3 generalised-alpha step for the constrained equations (Arnold & Bruls 2007).

Unknowns at t_{n+1} = t_n + h: the positions q, velocities v, accelerations q'' and the
multipliers lambda of :class:`~pipeline.solver.constrained.ConstrainedSystem`, tied by

    a_{n+1} = (alpha_f q''_n - alpha_m a_n + (1 - alpha_f) q''_{n+1}) / (1 - alpha_m)
    q_{n+1} = q_n + h v_n + h^2 ((1/2 - beta) a_n + beta a_{n+1})
    v_{n+1} = v_n + h ((1 - gamma) a_n + gamma a_{n+1})
    M q'' - rhs + C^T lambda = 0,   c(q) = 0          (at t_{n+1}, U coordinates)

(a: the algorithm's acceleration-like variable). Newton on (q_U, lambda) from the prediction
q''_{n+1} = q''_n: a correction dq moves q by dq, v by gamma' dq and q'' by beta' dq. (A
linear extrapolation of q'' from the last two states saves a quarter of the iterations but
lets Newton stop earlier: over 10 s of the parallelogram its error grew 100-fold; not used.)
(beta' = (1 - alpha_m) / (beta h^2 (1 - alpha_f)), gamma' = gamma / (beta h)). The iteration
matrix is scaled so that its condition does not grow as h -> 0 (Bottasso, Bauchau & Cardona
2007): the dynamic rows divided by beta', the multipliers by beta' s (s a mass scale),

    [ S      s C^T ] [ dq ]     [ -G / beta' ]        S = (dG/dq) / beta'
    [ s C   -eps s ] [ dmu]  =  [ -s c       ]          = M + (gamma'/beta') D_t + K_t / beta',

with a small regularisation eps of the constraint block: redundant closure rows (a planar
loop's out-of-plane rows, a parallelogram's extra bar) and singular positions (every bar
aligned) leave C rank-deficient, and the regularised matrix stays regular there while the
Newton fixed point is still the exact solution. S is M(q) of the step's first iterate plus a
finite-difference Jacobian of the rest, (dG/dq)/beta' - M, taken along the Newton direction,
kept across steps and refreshed when Newton slows down (modified Newton). Keeping the mass
matrix current matters for chains of many bodies: it is the largest part of S and the one
that changes fastest as the machine moves, and with the whole S kept a swinging 64-bar chain
needed a fresh finite-difference matrix (64 evaluations) every 2.6 steps; now one in 200.
The matrix is factored once a step (and again after a refresh), not at every iteration:
the iterations move q by far less than a step does, and the LU of a 64-bar chain costs
about what an evaluation of its equations does (336 against 628 us a step, same
iterations).

Why this method: positions and the branch come from Newton on every coordinate started from a
prediction of the last *accepted* step, so the mechanism cannot change assembly branch unless
Newton converges far from the prediction, and that rejects the step (``jump``). It is second
order for q and v (q'' and lambda too, from consistent initial accelerations) and damps the
highest frequencies by the user's rho_inf.

The step is compiled once (:mod:`pipeline.solver.dae_kernels`, driven by
:class:`pipeline.solver.index3_compiled.CompiledStepper`); this module holds its states and
outcomes. Its numpy oracle, the same iteration written with the numpy equations, lives in
``tests/solver/index3_numpy.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pipeline.solver.constrained import REGULARISATION, ConstrainedState, ConstrainedSystem

__all__ = ["StepOutcome", "StepState", "powers"]


@dataclass(frozen=True)
class StepState:
    """An accepted state: t (s), q, v, qdd (n,), a (n,) the algorithm's acceleration-like
    variable, lam (m,) multipliers, powers (2,) the driver power and minus the dissipated
    power there (W; from the index-1 accelerations and multipliers of the state: the
    index-3 multipliers carry O(h) errors after the start and after step-size changes);
    z, zd, b (nz,) the force elements' own states, their rates and the first-order
    method's acceleration-like variable (empty without such elements)."""

    t: float
    q: np.ndarray
    v: np.ndarray
    qdd: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    powers: np.ndarray
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    zd: np.ndarray = field(default_factory=lambda: np.zeros(0))
    b: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass(frozen=True)
class StepOutcome:
    """Result of one attempted step: ``state`` (None if it failed), Newton ``iterations``,
    ``why`` it failed ("newton", "jump", "evaluation"), the largest Newton correction
    ``correction`` (in coordinate units scaled by ``unit``) and the closure residual."""

    state: StepState | None
    iterations: int
    why: str = ""
    correction: float = 0.0
    closure: float = 0.0


def powers(cs: ConstrainedSystem, st: ConstrainedState, v: np.ndarray) -> np.ndarray:
    """(driver power, -dissipated power) W at the state of ``st`` with rates v: the
    drivers' forces from the index-1 accelerations and multipliers there."""
    p_nc = float(st.terms.Q_nonconservative @ v)
    if not cs.P.size:
        return np.array([0.0, -p_nc])
    qdd, lam = cs.accelerations(st, eps=REGULARISATION)
    return np.array([float(cs.driver_forces(st, qdd, lam) @ v[cs.P]), -p_nc])
