"""Time integration of the partitioned equations (the seed's method) on a fixed output grid.

The first-order state is y = [q_I, q'_I, W_d, E_d]: independent coordinates,
their rates, the work W_d done by the drivers and the energy E_d removed by
the non-conservative terms (integrated with the motion so the energy balance
T + V + E_d - W_d = const closes to the integrator's tolerance).
Any scipy ``OdeSolver`` steps it; dense output fills the output grid. A
failure (step-size collapse, a loop that cannot close, a singular mass
matrix) ends the run with the history so far, ``success=False`` and a message.

Branch continuity: every position Newton starts from a prediction of the last *accepted*
state (never from a rejected trial stage), and an accepted step whose closed configuration
left the Taylor prediction from the previous accepted state by more than ``jump`` (natural
coordinate units) is repeated with a quarter of its size: a long explicit step whose stages
closed the loops on another assembly branch is not kept. If even short steps cannot follow
the loops the run stops and says so (the DAE formulation passes such places).
"""

from __future__ import annotations

import logging
import time

import numpy as np

from pipeline.core.errors import ConfigError, PipelineError
from pipeline.core.progress import progress_counter
from pipeline.dynamics.energy import energies
from pipeline.dynamics.partition import partition_system, reduced_state, repartition
from pipeline.kinematics.failures import ClosureError, SingularConfigurationError
from pipeline.solver.constrained import ConstrainedSystem, drivers_at, same_time
from pipeline.solver.monitors import StallWatch
from pipeline.solver.result import ENERGY_KEYS, SimulationResult

logger = logging.getLogger(__name__)

__all__ = ["run"]


class _Rhs:
    """Right-hand side with the position Newton started from a prediction of the last
    closed state (so that it usually converges without an iteration)."""

    MAX_PREDICTED_MOVE = 0.1  # rad, m, modal units: larger predicted moves are not trusted

    def __init__(self, system, part, q_guess):
        self.system, self.part, self.guess, self.count = system, part, q_guess, 0
        self.t_last, self.steps, self.reselections = float("nan"), 0, []
        self.rejected, self.last_error = 0, None
        self.nI = part.independent.size
        self.last = None  # (t, y[:2 nI], ReducedState) of the last evaluation
        self.accepted = None  # the same of the last accepted state: predictions start there
        self._drive = None  # (t, driver_state at t)
        self.left_of = None  # the drivers' break the run steps up to (drivers_at)

    def accept(self, t, y):
        """Make (t, y) the accepted state the next predictions start from."""
        self.accepted = (t, y[:2 * self.nI].copy(), self.state_at(t, y))
        self.guess = self.accepted[2].q

    def predict(self, t, q_I):
        """(n,) guess of the closed configuration at (t, q_I): second-order Taylor series
        of the last accepted state in time, corrected to first order for where q_I is."""
        if self.accepted is None or self.accepted[2].B.shape[1] != q_I.size:
            return self.guess
        t0, _, st = self.accepted
        dt = t - t0
        q = st.q + dt * st.qd + (0.5 * dt * dt) * st.qdd
        q += st.B @ (q_I - q[self.part.independent])
        # a trial stage far from the last state (a long explicit step, a diverging one):
        # the last closed configuration is the safer start
        return q if np.abs(q - st.q).max(initial=0.0) <= self.MAX_PREDICTED_MOVE else st.q

    def state(self, t, y):
        nI = self.nI
        q_I = y[:nI]
        if self._drive is None or self._drive[0] != t:  # Newton iterations share a time
            self._drive = (t, drivers_at(self.part, t, self.left_of))
        st = reduced_state(self.system, self.part, q_I, y[nI:2 * nI], t, self.predict(t, q_I),
                           self._drive[1])
        self.last = (t, y[:2 * nI].copy(), st)
        return st

    def state_at(self, t, y):
        """As :meth:`state`, reusing the last evaluation when it was at this very state
        (an output time on a step end: an implicit step's last Newton evaluation)."""
        if self.last is not None:
            t0, y0, st = self.last
            if abs(t - t0) <= same_time(t) and np.array_equal(y0, y[:2 * self.nI]):
                return st
        return self.state(t, y)

    def __call__(self, t, y):
        self.count += 1
        self.t_last = t
        if not np.all(np.isfinite(y)):  # a diverging trial stage: reject it (see below)
            self.rejected += 1
            return np.full(y.shape, np.nan)
        try:
            st = self.state(t, y)
        except (ClosureError, SingularConfigurationError) as exc:
            # A trial stage of a too-long step can leave the loops' reach. NaN derivatives
            # make scipy's error norm NaN, which rejects the step and shrinks it (x0.2 for
            # the Runge-Kutta methods; a failed Newton for the implicit ones); only if the
            # step collapses does the run fail, and then with this reason.
            self.rejected += 1
            self.last_error = exc
            return np.full(y.shape, np.nan)
        power = float(st.terms.Q_nonconservative @ st.qd)
        p_drivers = float(st.driver_forces @ st.qd[self.part.driven])
        return np.concatenate([y[self.nI:2 * self.nI], st.qdd_I, [p_drivers, -power]])


def check_arguments(system, q0, qd0, t_span, t_eval, rtol, atol):
    """(q0, qd0, t0, t1, t_eval) validated; ConfigError naming the bad argument."""
    n = system.mechanism.n
    q0, qd0 = np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)
    for name, v in (("q0", q0), ("qd0", qd0)):
        if v.shape != (n,) or not np.all(np.isfinite(v)):
            raise ConfigError(f"simulate: {name}: expected {n} finite values, got shape {v.shape}")
    t0, t1 = (float(x) for x in t_span)
    if not (np.isfinite(t0) and np.isfinite(t1) and t1 > t0):
        raise ConfigError(f"simulate: t_span: expected finite (t0, t1) with t1 > t0, got {t_span}")
    te = np.linspace(t0, t1, 101) if t_eval is None else np.asarray(t_eval, dtype=float)
    if te.ndim != 1 or te.size == 0 or np.any(np.diff(te) <= 0) or te[0] < t0 or te[-1] > t1:
        raise ConfigError("simulate: t_eval: expected increasing times inside t_span")
    if not (rtol > 0 and np.all(np.asarray(atol) > 0)):
        raise ConfigError(f"simulate: rtol, atol: expected values > 0, got {rtol}, {atol}")
    return q0, qd0, t0, t1, te


def _record(rhs, t, y, out):
    st = rhs.state_at(t, y)
    e = energies(rhs.system, st.terms.tree, st.q, st.qd, M=st.terms.M)
    e["dissipated"], e["driver_work"] = float(y[-1]), float(y[-2])
    e["total"] = (e["kinetic"] + e["gravity"] + e["elastic"] + e["forces"] + e["dissipated"]
                  - e["driver_work"])
    r = st.residual
    out.append((t, st.q, st.qd, st.qdd, e, float(np.abs(r).max()) if r.size else 0.0,
                st.driver_forces))


def _reselect(solver, rhs, make):
    """Restart ``solver`` in better-conditioned independent coordinates if needed."""
    J = None if rhs.last is None else rhs.last[2].J
    new = repartition(rhs.system, rhs.part, rhs.guess, J=J)
    if new is None:
        return solver
    if np.array_equal(new.independent, rhs.part.independent):
        rhs.part = new  # same coordinates, a new reference conditioning
        return solver
    st = rhs.state(solver.t, solver.y)
    rhs.part, rhs.nI = new, new.independent.size
    rhs.last = None  # its velocity map is in the old coordinates
    I = new.independent
    y = np.concatenate([st.q[I], st.qd[I], solver.y[-2:]])
    rhs.reselections.append(float(solver.t))
    logger.info("re-selected independent coordinates at t = %.6g s: %s", solver.t,
                [rhs.system.mechanism.coordinates[i] for i in I])
    solver = make(solver.t, y)
    rhs.accept(solver.t, y)
    return solver


def _deviation(st0, st1, h: float, unit: np.ndarray, closed: np.ndarray) -> float:
    """Largest |q1 - (q0 + h q0' + h^2/2 q0'')| over the coordinates ``closed`` by position
    analysis, in natural coordinate units. The integrated coordinates are left out: a stiff
    mode moves them far from a Taylor prediction on a long implicit step without any change
    of branch."""
    c = closed
    pred = st0.q[c] + h * st0.qd[c] + (0.5 * h * h) * st0.qdd[c]
    return float(np.abs((st1.q[c] - pred) / unit[c]).max(initial=0.0))


class _Stepper:
    """Accepted steps of ``solver`` with branch-continuity rejection and budgets."""

    #: accepted steps under a reduced step cap before the user's max_step is restored
    CAPPED_STEPS = 20

    def __init__(self, rhs, make, t0, t1, max_step, max_steps, max_wall, jump, tic, cs):
        self.rhs, self.make, self.cs = rhs, make, cs
        self.span, self.max_step = t1 - t0, max_step
        self.max_steps, self.max_wall, self.jump, self.tic = max_steps, max_wall, jump, tic
        self.unit = rhs.system.mechanism.coordinate_units
        self.rejected, self.capped = 0, 0
        self.stall = StallWatch(self.span)

    def across(self, solver):
        """A solver started afresh after the drivers' break it reached, with the impulse a
        jump of a driven rate needs (ConstrainedSystem.across_break)."""
        rhs, t = self.rhs, solver.t_bound
        st = rhs.state(t, solver.y)
        v, dw = self.cs.across_break(t, st.q, st.qd)
        I = rhs.part.independent
        y = np.concatenate([solver.y[:rhs.nI], v[I], solver.y[-2:] + np.array([dw, 0.0])])
        solver = self.make(t, y)
        rhs.last = None
        rhs.accept(t, y)
        return solver

    def step(self, solver):
        """(solver after one accepted step, or None with a message)."""
        rhs = self.rhs
        if solver.status == "finished":  # at a break of the drivers: start afresh after it
            solver = self.across(solver)
        while True:
            if rhs.steps >= self.max_steps:
                return solver, (f"step budget of {self.max_steps} steps exhausted at "
                                f"t = {solver.t:.6g} s")
            if self.max_wall is not None and time.perf_counter() - self.tic > self.max_wall:
                return solver, (f"wall-time budget of {self.max_wall:g} s exhausted at "
                                f"t = {solver.t:.6g} s")
            if rhs.steps:
                solver = _reselect(solver, rhs, self.make)
            t_prev, y_prev, acc = solver.t, solver.y.copy(), rhs.accepted
            msg = solver.step()
            if solver.status == "failed":
                why = f" (last position failure: {rhs.last_error})" if rhs.last_error else ""
                return solver, f"integrator failed at t = {solver.t:.6g} s: {msg}{why}"
            h = solver.t - t_prev
            st = rhs.state_at(solver.t, solver.y)
            dev = _deviation(acc[2], st, h, self.unit, rhs.part.kin.dependent) \
                if acc is not None and acc[2].q.shape == st.q.shape else 0.0
            if dev > self.jump:  # its stages closed the loops elsewhere: repeat it, shorter
                self.rejected += 1
                cap = 0.25 * h
                if cap < 1e-10 * max(self.span, abs(t_prev)):
                    return solver, (
                        f"the loops cannot be followed at t = {t_prev:.6g} s: even short "
                        f"steps close them {dev:.3g} away from the predicted configuration "
                        "(another assembly branch, a singular position); the DAE "
                        "formulation (formulation='dae') passes such places")
                solver = self.make(t_prev, y_prev, first_step=cap, max_step=cap)
                rhs.accepted = acc
                self.capped = self.CAPPED_STEPS
                continue
            rhs.accept(solver.t, solver.y)
            rhs.steps += 1
            stalled = self.stall(solver.t)
            if stalled:
                return solver, stalled
            if self.capped:
                self.capped -= 1
                if not self.capped and solver.status == "running":
                    solver = self.make(solver.t, solver.y, first_step=h)
            return solver, None


def _march(solver, rhs, te, y0, progress, out, stepper):
    """Step over the grid ``te``, appending to ``out``; returns (message or None, output
    seconds). Before each step the partition is re-selected if it became ill-conditioned
    (the solver restarts from the current state; the step after a restart provides the
    dense output, so outputs never straddle a restart)."""
    t_out = 0.0
    rhs.accept(solver.t, solver.y)
    dense, dense_of = None, None  # one interpolant per step, however many outputs it holds
    with progress_counter(te.size, "simulating", progress) as advance:
        for k, tk in enumerate(te):
            while solver.t < tk - same_time(tk) and solver.status != "failed":
                solver, msg = stepper.step(solver)
                if msg:
                    return msg, t_out
            s0 = time.perf_counter()
            if solver.t_old is None:
                y = y0 if solver.t == te[0] else solver.y
            elif abs(solver.t - tk) <= same_time(tk):  # on a step end: no interpolation
                y = solver.y
            else:
                if dense_of != (solver, solver.t_old, solver.t):  # a restart makes a new solver
                    dense, dense_of = solver.dense_output(), (solver, solver.t_old, solver.t)
                y = dense(tk)
            if not np.all(np.isfinite(y)):  # the step's interpolation stages failed
                why = f" ({rhs.last_error})" if rhs.last_error else ""
                return (f"the partitioned formulation cannot evaluate the state at t = "
                        f"{tk:.6g} s: the loops cannot be closed there in its coordinates{why};"
                        " formulation='dae' passes singular positions"), t_out
            _record(rhs, tk, y, out)
            advance(k + 1)
            t_out += time.perf_counter() - s0
    return None, t_out


def run(system, q0, qd0, t0, t1, te, solver_cls, name, rtol, atol, progress,
        max_step, options=None, max_steps=1_000_000, max_wall=None,
        jump=0.1) -> SimulationResult:
    """Integrate from a consistent (q0, qd0) (see :func:`pipeline.solver.simulate`)."""
    tic = time.perf_counter()
    part = partition_system(system, q0)
    rhs = _Rhs(system, part, q0)
    I = part.independent
    y0 = np.concatenate([q0[I], qd0[I], [0.0, 0.0]])
    out, msg, t_out = [], None, 0.0
    stepper = None
    cs = ConstrainedSystem(system)
    try:
        def make(t, y, first_step=None, max_step=max_step):
            extra = {}
            if getattr(solver_cls, "SECOND_ORDER", False):  # y = [q_I, v_I, work, dissipated]
                extra = {"n_second": rhs.nI, **(options or {})}
            # up to the drivers' next break, where the run starts afresh (dae._Run.march)
            rhs.left_of, rhs._drive = cs.next_break(t, t1), None
            bound = t1 if rhs.left_of is None else rhs.left_of
            if first_step is not None:
                first_step = min(first_step, bound - t)
            return solver_cls(rhs, t, y, bound, rtol=rtol, atol=atol, max_step=max_step,
                              first_step=first_step, **extra)

        stepper = _Stepper(rhs, make, t0, t1, max_step, max_steps, max_wall, jump, tic, cs)
        msg, t_out = _march(make(t0, y0), rhs, te, y0, progress, out, stepper)
    # ValueError: scipy's implicit methods refuse a non-finite Jacobian (a diverging trial
    # state); the run ends there with its history, like any other integrator failure
    except (PipelineError, np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
        from pipeline.kinematics.joints import gimbal_lock_note

        msg = (f"integration failed at t = {rhs.t_last:.6g} s (last output t = "
               f"{out[-1][0] if out else t0:.6g} s): {exc}"
               + gimbal_lock_note(system.mechanism, out[-1][1] if out else q0))
    total = time.perf_counter() - tic
    if msg:
        logger.warning("simulation: %s", msg)
    stats = {"rejected": stepper.rejected if stepper else 0, "evaluations": rhs.count}
    return _result(system, part, out, msg, rhs.steps, rhs.count, name,
                   {"integrate": total - t_out, "output": t_out, "total": total},
                   tuple(rhs.reselections), stats)


def _result(system, part, out, msg, steps, n_rhs, name, timings,
            reselections, stats) -> SimulationResult:
    n = system.mechanism.n
    names = system.mechanism.coordinates
    k = len(out)
    stack = (lambda j: np.array([o[j] for o in out]).reshape(k, n))
    en = {key: np.array([o[4][key] for o in out]) for key in ENERGY_KEYS}
    return SimulationResult(
        success=msg is None, status=0 if msg is None else -1,
        message="finished" if msg is None else msg, coordinates=system.mechanism.coordinates,
        t=np.array([o[0] for o in out]), q=stack(1), qd=stack(2), qdd=stack(3), energies=en,
        closure_residual=np.array([o[5] for o in out]), n_steps=steps, n_rhs=n_rhs,
        timings=timings, method=name, driven=tuple(names[i] for i in part.driven),
        driver_forces=np.array([o[6] for o in out]).reshape(k, part.driven.size),
        reselections=reselections, step_stats=stats, formulation="partitioned")
