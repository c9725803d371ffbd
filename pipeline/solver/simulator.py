"""Advance a machine step by step from outside: a discrete controller, hardware in the loop,
a co-simulation master (set the inputs, do a step, read the state; FMI's rhythm).

>>> sim = Simulator(system, q0, step=1e-3, inputs=["motor"])       # doctest: +SKIP
>>> while sim.t < 2.0:                                               # doctest: +SKIP
...     sim.step(0.01, {"motor": -kp * (sim.q[i] - goal) - kd * sim.qd[i]})
>>> r = sim.result()        # every communication point, checked: r.verdict   # doctest: +SKIP

Inputs are named when the simulator is built, each with its start value:

* a force element's name: its history value (the element's force, torque or point force
  times this number; a ``JointForce(name, coordinate, 1.0)`` takes the force in N or N m
  itself; a hydraulic cylinder's valve command in [-1, 1], or its controller's reference
  when a PID commands the valve), held constant over each step (zero-order hold). It
  replaces the element's own history (the cylinder's command; the controller's reference).
* a driven coordinate's name: its value (m or rad), reached linearly over each step
  (first-order hold: rate constant over the step, acceleration zero within it). It
  replaces the coordinate's driver; it starts from that driver's value at t0, at rest.

The integrator is the index-3 generalised-alpha of :func:`pipeline.solver.simulate` with
a fixed step, run by the same stepping driver (:mod:`pipeline.solver.dae`): a step ``dt``
of the caller is done in steps of ``step`` (the last one shortened if dt is not a
multiple), and the method's own variables (algorithmic accelerations, iteration matrix,
the energy flows) carry from one call to the next. So a run in many calls equals one
``simulate`` call at the same step and output times to round-off, and :meth:`result`
gives the same trust checks.

The integration error is estimated call by call (``error_estimate``): each call is done
again from the same state at twice the step (or, for a call shorter than two steps, at
half the step) and the difference is its error. Inputs computed from the state (a
controller) make a replay of the whole run with the recorded inputs the wrong measure --
the replayed motion drifts from the one the inputs were computed for, and nothing
corrects it -- so the errors of the calls are summed instead: the accumulated error of a
motion that does not amplify errors (a stable, controlled machine), conservative where
it damps them. Where the motion amplifies them it reads low: a free four-bar over 50
calls of 10 steps, 1.7x the error; over 500 calls of one step, 0.8x
(tests/solver/test_simulator.py). For inputs that do not depend on the state (a
schedule) ``result(replay=True)`` replays the recorded inputs at twice the step, as
:func:`~pipeline.solver.simulate` does. The estimate costs about half the run again (a
call of one step: twice); :attr:`error_ratio` gives it after every call. Where a call's
check run fails (its other step cannot follow the motion) the call still stands; the
estimate is then unavailable for the rest of the run, and :meth:`result` says so in its
warnings (the run is not known to be within its tolerance).
"""

from __future__ import annotations

import logging
import math
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from pipeline.core.errors import ConfigError, SolverError
from pipeline.kinematics.driver_base import Driver, out
from pipeline.solver.constrained import ConstrainedSystem
from pipeline.solver.dae import _Run, dae_stepper, march_guarded
from pipeline.solver.generalized_alpha import coefficients
from pipeline.solver.index3 import StepState
from pipeline.solver.outputs import OutputGrid, same_time
from pipeline.solver.result import SimulationResult

__all__ = ["Simulator", "SimulatorState"]

logger = logging.getLogger(__name__)


class _HeldValue:
    """A force element's history set from outside: value(t) is the value last set."""

    def __init__(self, value: float):
        self.x = float(value)

    def value(self, t):
        return out(t, self.x)


class _HeldMotion(Driver):
    """A driven coordinate set from outside: linear from (ta, xa) to (tb, xb)."""

    def __init__(self, t: float, x: float):
        self.ta, self.xa, self.tb, self.xb = t, float(x), t, float(x)

    @property
    def slope(self) -> float:
        return 0.0 if self.tb <= self.ta else (self.xb - self.xa) / (self.tb - self.ta)

    def value(self, t):
        return out(t, self.xa + self.slope * (np.asarray(t, dtype=float) - self.ta))

    def rate(self, t):
        return out(t, self.slope)

    def accel(self, t):
        return out(t, 0.0)


@dataclass(frozen=True)
class SimulatorState:
    """Everything a :class:`Simulator` continues from (``Simulator.state``).

    t : s.  q, qd, qdd : (n,) coordinates, rates, accelerations.  a : (n,) the method's
    acceleration-like variable.  lam : (m,) multipliers.  powers : (2,) driver power and
    minus the dissipated power, W.  work : (2,) driver work and dissipated energy so far,
    J.  inputs : {name: value held (forces) or reached (drivers) at t}.
    memory : what the next step reuses (its iteration matrix): restored with the rest, the
    continuation repeats the first one bit for bit.  z, zd, b : (nz,) the force elements'
    own states (a hydraulic cylinder's pressures, Pa), their rates and the method's
    variable for them.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    powers: np.ndarray
    work: np.ndarray
    inputs: Mapping[str, float] = field(default_factory=dict)
    memory: object = None
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    zd: np.ndarray = field(default_factory=lambda: np.zeros(0))
    b: np.ndarray = field(default_factory=lambda: np.zeros(0))


class Simulator:
    """A machine advanced by calls of :meth:`step` (module docstring).

    Parameters
    ----------
    model : a :class:`pipeline.dynamics.System`, or anything with ``.system`` (a
        workflow's Machine: then q0 and qd0 default to its assembled start).
    q0, qd0 : (n,) start coordinates and rates (as :func:`~pipeline.solver.simulate`).
    t0 : start time, s.
    step : the integration step, s (fixed).
    inputs : the names set from outside (a list: start values from the model; a mapping:
        name -> start value).
    rho_inf : spectral radius at infinite frequency, [0, 1].
    rtol, atol : the error accepted (the fixed-step estimate; the defaults of
        :func:`~pipeline.solver.simulate`).
    error_estimate : estimate each call's integration error (module docstring); False
        skips it (the verdict then says nothing of the integration error).
    """

    def __init__(self, model, q0=None, qd0=None, t0: float = 0.0, *, step: float,
                 inputs=(), rho_inf: float = 0.8, rtol: float = 1e-8, atol: float = 1e-10,
                 error_estimate: bool = True):
        from pipeline.solver.integrate import check_arguments
        from pipeline.solver.start import consistent_start

        system = getattr(model, "system", model)
        q0 = getattr(model, "q0", None) if q0 is None else q0
        if q0 is None:
            raise ConfigError("Simulator: q0: expected the start coordinates")
        if qd0 is None:
            qd0 = getattr(model, "qd0", None)
        qd0 = np.zeros(system.mechanism.n) if qd0 is None else qd0
        if not (isinstance(step, int | float) and math.isfinite(step) and step > 0):
            raise ConfigError(f"Simulator: step: expected a fixed step > 0 s, got {step!r}")
        coefficients(rho_inf)  # validates it
        t0 = float(t0)
        q0, qd0, t0, _, _ = check_arguments(system, q0, qd0, (t0, t0 + step), None, rtol, atol)
        self._start, self._model = (q0.copy(), qd0.copy(), t0), system
        self._declared = dict(inputs) if isinstance(inputs, Mapping) else \
            {name: None for name in inputs}
        self.system, self._held = _with_inputs(system, self._declared, t0)
        self._log: list[tuple[float, dict]] = []  # (end time, inputs set) of every call
        self.step_size, self.rho_inf, self.rtol, self.atol = float(step), rho_inf, rtol, atol
        q0, qd0 = consistent_start(self.system, q0, qd0, t0)
        self._cs = cs = ConstrainedSystem(self.system)
        self._stepper = dae_stepper(cs, rtol, atol, self.step_size, rho_inf)
        self._run = _Run(cs, self.system.mechanism.coordinate_units, t0, t0, rtol, atol,
                         self.step_size, np.inf, sys.maxsize, None, time.perf_counter())
        # the stall watch and the step floor scale with the step, not an unknown span
        self._run.span = self._run.stall.span = 1e4 * self.step_size
        self._grid = OutputGrid(cs, np.array([t0]), getattr(self._stepper, "output", None))
        self._seconds = 0.0
        #: accumulated error estimate (n,) at every output row (error_estimate), and the
        #: steppers at twice and at half the step that make it
        self._deviation = [np.zeros(cs.n)] if error_estimate else None
        self._state_deviation = [np.zeros(len(self.system.state_names))]  # (nz,) alike
        self._unavailable = ""  # why the estimate was lost (a check run failed), if it was
        self._checks: dict[float, tuple] = {}
        q, v = cs.with_drivers(t0, q0, qd0)
        s, self._work, msg = march_guarded(self._run, self._stepper, (t0, q, v), np.zeros(2),
                                           self._grid, _quiet)
        if msg:
            raise SolverError(f"Simulator: the start cannot be integrated: {msg}")
        self._s = s
        self._size = np.abs(self._grid.rows[-1][1])  # (n,) largest |q| recorded
        self._state_size = np.abs(self._grid.rows[-1][8])  # (nz,) largest |z| recorded

    # ------------------------------------------------------------------ reading
    @property
    def t(self) -> float:
        """Time reached, s."""
        return float(self._s.t)

    @property
    def q(self) -> np.ndarray:
        """(n,) coordinates at :attr:`t` (``system.mechanism.coordinates`` order)."""
        return self._s.q.copy()

    @property
    def qd(self) -> np.ndarray:
        """(n,) rates at :attr:`t`."""
        return self._s.v.copy()

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(self.system.mechanism.coordinates)

    @property
    def inputs(self) -> dict[str, float]:
        """{name: the value now held (forces) or reached (drivers)}."""
        return {k: (h.x if isinstance(h, _HeldValue) else h.xb) for k, h in self._held.items()}

    @property
    def state(self) -> SimulatorState:
        """A copy of the state (restore it with :meth:`set_state`)."""
        s = self._s
        return SimulatorState(s.t, s.q.copy(), s.v.copy(), s.qdd.copy(), s.a.copy(),
                              s.lam.copy(), np.array(s.powers, dtype=float),
                              self._work.copy(), dict(self.inputs), self._stepper.memory(),
                              s.z.copy(), s.zd.copy(), s.b.copy())

    def set_state(self, state: SimulatorState) -> None:
        """Continue from ``state`` (taken from this simulator): the history after its time
        is dropped, the held inputs are its own."""
        if not isinstance(state, SimulatorState) or state.q.shape != self._s.q.shape:
            raise ConfigError("Simulator.set_state: expected a SimulatorState of this machine")
        self._s = StepState(float(state.t), state.q.copy(), state.qd.copy(),
                            state.qdd.copy(), state.a.copy(), state.lam.copy(),
                            np.array(state.powers, dtype=float), state.z.copy(),
                            state.zd.copy(), state.b.copy())
        self._work = np.array(state.work, dtype=float)
        for name, x in state.inputs.items():
            h = self._held[name]
            if isinstance(h, _HeldValue):
                h.x = float(x)
            else:
                h.ta = h.tb = float(state.t)
                h.xa = h.xb = float(x)
        if state.memory is None:
            self._stepper.reset()
        else:
            self._stepper.recall(state.memory)
        keep = state.t + same_time(state.t)
        g = self._grid
        g.rows = [row for row in g.rows if row[0] <= keep]
        g.te, g.k = np.array([row[0] for row in g.rows]), len(g.rows)
        if self._deviation is not None:
            del self._deviation[len(g.rows):]
            del self._state_deviation[len(g.rows):]
        del self._log[len(g.rows) - 1:]
        self._size = np.abs(np.array([row[1] for row in g.rows])).max(axis=0)
        self._state_size = np.abs(np.array([row[8] for row in g.rows])).max(axis=0)

    # ------------------------------------------------------------------ stepping
    def step(self, dt: float, inputs: Mapping[str, float] | None = None) -> float:
        """Advance by ``dt`` s with ``inputs`` ({name: value}; names declared at build,
        others keep their value). Returns the time reached, s.

        Raises
        ------
        ConfigError
            A bad dt, an undeclared input, a value that is not a finite number.
        SolverError
            The step could not be completed (Newton failed even at a much smaller step);
            the state is left where the call began.
        """
        if not (isinstance(dt, int | float | np.floating) and math.isfinite(dt) and dt > 0):
            raise ConfigError(f"Simulator.step: dt: expected a time > 0 s, got {dt!r}")
        values = _check_inputs(inputs or {}, self._held)
        tic = time.perf_counter()
        t0, t1 = self._s.t, self._s.t + float(dt)
        before = self.state
        jumps = False
        for name, h in self._held.items():
            if isinstance(h, _HeldValue):
                jumps |= values.get(name, h.x) != h.x
                h.x = values.get(name, h.x)
            else:
                slope = h.slope
                h.ta, h.xa, h.tb = t0, h.xb, t1
                h.xb = values.get(name, h.xb)
                # a slope the round-off of the values changes is no jump (a restart is
                # an O(h^2) change of its own)
                jumps |= not math.isclose(h.slope, slope, rel_tol=1e-9,
                                          abs_tol=1e-12 * (abs(h.xb) + 1.0) / float(dt))
        self._run.t1 = t1
        self._grid.te = np.append(self._grid.te, t1)
        self._log.append((t1, values))
        start, work = self._s, self._work
        if jumps:
            # a force or a driven rate that jumps: the method's acceleration-like variable
            # would lag the new accelerations for several steps, an error of the order of
            # the step per jump (first order overall: a PD loop sampled every two steps
            # was 10x the error the calls' check saw); start afresh from the state instead,
            # with the impulse a driven rate's jump needs
            v, dw = self._cs.across_break(t0, start.q, start.v, before=start.v[self._cs.P])
            start = self._stepper.start(t0, start.q, v, *((start.z,) if start.z.size else ()))
            work = work + np.array([dw, 0.0])
        s, work, msg = march_guarded(self._run, self._stepper, start, work,
                                     self._grid, _quiet)
        if not msg and self._deviation is not None:
            why = self._check_call(start, before.work, t1)
            if why:  # the user's step went through: only the estimate is lost
                logger.warning("Simulator.step from t = %.6g s: %s; the error is not "
                               "estimated from here on", t0, why)
                self._deviation, self._unavailable = None, f"at t = {t0:.6g} s {why}"
        self._seconds += time.perf_counter() - tic
        if msg:
            self.set_state(before)
            raise SolverError(f"Simulator.step from t = {t0:.6g} s by {dt:g} s: {msg}")
        self._s, self._work = s, work
        self._size = np.maximum(self._size, np.abs(self._grid.rows[-1][1]))
        self._state_size = np.maximum(self._state_size, np.abs(self._grid.rows[-1][8]))
        return self.t

    def _check_call(self, before: StepState, work: np.ndarray, t1: float) -> str | None:
        """The call from ``before`` (work (2,) there) to t1 again at twice the step (half
        the step for a call shorter than two steps); its difference to the recorded end,
        added to the accumulated error. Returns a failure message of the other run, or
        None."""
        h = self.step_size
        other = 2.0 * h if t1 - before.t >= 2.0 * h - same_time(t1) else 0.5 * h
        if other not in self._checks:
            run = _Run(self._cs, self.system.mechanism.coordinate_units, before.t, t1,
                       self.rtol, self.atol, other, np.inf, sys.maxsize, None, 0.0)
            run.span = run.stall.span = 1e4 * other
            self._checks[other] = (run, dae_stepper(self._cs, self.rtol, self.atol, other,
                                                    self.rho_inf, warn=False))
        run, stepper = self._checks[other]
        run.t1, run.h, run.nominal = t1, other, other
        grid = OutputGrid(self._cs, np.array([t1]), getattr(stepper, "output", None))
        s0 = StepState(before.t, before.q.copy(), before.v.copy(), before.qdd.copy(),
                       before.a.copy(), before.lam.copy(), np.array(before.powers),
                       before.z.copy(), before.zd.copy(), before.b.copy())
        _, _, msg = march_guarded(run, stepper, s0, work.copy(), grid, _quiet)
        if msg or not grid.rows:
            return f"the check at {other:g} s steps failed: {msg}"
        # |q_h - q_2h| is the h run's error for a first-order method, and |q_h - q_h/2|
        # half of it: conservative for the method's second order (step_error)
        scale = 1.0 if other > h else 2.0
        here = np.abs(self._grid.rows[-1][1] - grid.rows[-1][1]) * scale
        self._deviation.append(self._deviation[-1] + here)
        here = np.abs(self._grid.rows[-1][8] - grid.rows[-1][8]) * scale
        self._state_deviation.append(self._state_deviation[-1] + here)
        return None

    @property
    def error_ratio(self) -> float | None:
        """The accumulated error estimate over the tolerance (1: at it), largest over the
        coordinates and the calls so far; None without ``error_estimate`` or once a check
        run failed (the estimate is lost, module docstring). It costs as
        much after the millionth call as after the first: the summed errors only grow,
        so the largest is the last row's (``result()`` reports the same figure)."""
        from pipeline.solver.step_error import state_tolerance, tolerance

        if self._deviation is None:
            return None
        mech = self.system.mechanism
        U = self._cs.U
        tol = tolerance(self._size, U, self.rtol, self.atol, mech.coordinate_units,
                        mech.modal_index)
        scaled = np.concatenate([
            self._deviation[-1][U] / tol,
            self._state_deviation[-1] / state_tolerance(
                self._state_size, self.rtol, self.atol, self.system.state_scales())])
        if not np.all(np.isfinite(scaled)):
            return np.inf
        return float(scaled.max(initial=0.0))

    def error_figures(self, r: SimulationResult, deviation=None, states=None) -> dict:
        """An estimated error of r's first k outputs against this simulator's tolerance:
        ``deviation`` (k, n) in the coordinates and ``states`` (k, nz) in the element
        states, default the calls' summed estimate. Returns {"error_ratio" (1: at the
        tolerance), "error_coordinate", "error_time"} (pipeline.solver.step_error)."""
        from pipeline.solver.step_error import scaled_error, with_state_error

        mech = self.system.mechanism
        if deviation is None:
            deviation, states = np.array(self._deviation), np.array(self._state_deviation)
        out = scaled_error(r, deviation, self._cs.U, self.rtol, self.atol,
                           mech.coordinate_units, mech.modal_index)
        return with_state_error(out, r, states, self.rtol, self.atol,
                                self.system.state_scales())

    # ------------------------------------------------------------------ results
    def result(self, *, replay: bool = False, limits=None,
               stats: dict | None = None) -> SimulationResult:
        """The history at every communication point (and t0), with the trust checks of
        :func:`~pipeline.solver.simulate` (``verdict``). The integration error is the
        calls' accumulated estimate, or with ``replay`` (inputs that do not depend on the
        state) that of the recorded inputs replayed at twice the step (module docstring).
        ``stats``: figures the caller adds to ``step_stats`` to be judged with the rest (a
        co-simulation master's coupling error, :mod:`pipeline.solver.cosim`).
        """
        from pipeline.solver.monitors import Limits, judge

        r = self._raw()
        if stats:
            r = replace(r, step_stats={**r.step_stats, **stats})
        if replay and r.t.size > 1:
            tic = time.perf_counter()
            h = self.step_size
            short = np.diff(r.t).min() < 2.0 * h - same_time(r.t[-1])
            other = self._replay(0.5 * h if short else 2.0 * h)
            k = min(r.t.size, other.t.size)
            # as the calls' check: |q_h - q_h/2| is half the h run's first-order error
            factor = 2.0 if short else 1.0
            deviation = np.abs(r.q[:k] - other.q[:k]) * factor
            states = np.abs(r.states[:k] - other.states[:k]) * factor
            how = "the calls replayed at " + ("half" if short else "twice") + " the step"
            r = replace(r, step_stats={**r.step_stats,
                                       **self.error_figures(r, deviation, states),
                                       "error_seconds": time.perf_counter() - tic,
                                       "error_method": how})
        elif self._unavailable:
            r = replace(r, step_stats={**r.step_stats,
                                       "error_unavailable": self._unavailable})
        elif self._deviation is not None and r.t.size > 1:
            how = "each call again at another step, the errors summed"
            r = replace(r, step_stats={**r.step_stats, **self.error_figures(r),
                                       "error_method": how})
        return judge(self.system, r, limits or Limits(), t_span=(self._start[2], self.t))

    def copy(self, *, error_estimate: bool = False) -> Simulator:
        """A new simulator of the same machine, inputs, step and tolerances, at this one's
        state (its history from the same start; this one's later calls are not its)."""
        q0, qd0, t0 = self._start
        other = Simulator(self._model, q0, qd0, t0, step=self.step_size,
                          inputs=self._declared, rho_inf=self.rho_inf, rtol=self.rtol,
                          atol=self.atol, error_estimate=error_estimate)
        if self.t > t0:
            other.set_state(self.state)
        return other

    def _replay(self, step: float) -> SimulationResult:
        """The same calls with the recorded inputs at another step."""
        q0, qd0, t0 = self._start
        other = Simulator(self._model, q0, qd0, t0, step=step, inputs=self._declared,
                          rho_inf=self.rho_inf, rtol=self.rtol, atol=self.atol,
                          error_estimate=False)
        try:
            for t1, values in self._log[:len(self._grid.rows) - 1]:
                other.step(t1 - other.t, values)
        except SolverError:
            pass  # the estimate compares what the other run reached
        return other._raw()

    def history(self) -> SimulationResult:
        """The history at every communication point as recorded, without the trust checks
        or the error estimate of :meth:`result` (a co-simulation master comparing runs)."""
        return self._raw()

    def _raw(self) -> SimulationResult:
        return self._grid.result(None, self._run.steps, self._stepper.evaluations,
                                 self._seconds, "generalized_alpha",
                                 self._run.stats(self._stepper))


def _quiet(_k: int) -> None:
    """Progress callback of a stepped run (the caller shows its own)."""


def _check_inputs(values: Mapping, held: dict) -> dict[str, float]:
    if not isinstance(values, Mapping):
        raise ConfigError(f"Simulator.step: inputs: expected a mapping name -> value, got "
                          f"{type(values).__name__}")
    out = {}
    for name, x in values.items():
        if name not in held:
            raise ConfigError(f"Simulator.step: input {name!r} was not declared; declared: "
                              f"{sorted(held)} (Simulator(..., inputs=[...]))")
        if isinstance(x, bool) or not isinstance(x, int | float | np.number) \
                or not math.isfinite(float(x)):
            raise ConfigError(f"Simulator.step: input {name!r}: expected a finite number, "
                              f"got {x!r}")
        out[name] = float(x)
    return out


def _with_inputs(system, declared: dict, t0: float):
    """(the system with the declared inputs' histories and drivers replaced by held values,
    {name: the held object})."""
    forces = {f.name: f for f in system.forces}
    held, new_forces, drivers = {}, [], dict(system.drivers)
    for name, x in declared.items():
        if name in drivers:
            d = drivers[name]
            held[name] = h = _HeldMotion(t0, d.value(t0) if x is None else x)
            drivers[name] = h
        elif name in forces:
            f = forces[name]
            field_ = getattr(f, "HISTORY", "history")  # a valve's command, a force's history
            if not hasattr(f, field_):
                raise ConfigError(f"Simulator: input {name!r}: force element of type "
                                  f"{type(f).__name__} takes no input (it has no history)")
            if x is None:
                from pipeline.dynamics.forces.loads import history_value

                x = history_value(getattr(f, field_), t0, name)
            held[name] = _HeldValue(x)
        else:
            raise ConfigError(f"Simulator: input {name!r}: expected the name of a force "
                              f"element {sorted(forces)} or a driven coordinate "
                              f"{sorted(drivers)}")
    for f in system.forces:
        if f.name not in held:
            new_forces.append(f)
        elif hasattr(f, "with_input"):  # the contract's own (a controller: its reference)
            new_forces.append(f.with_input(held[f.name]))
        else:  # a duck-typed element: its history field
            new_forces.append(replace(f, **{getattr(f, "HISTORY", "history"): held[f.name]}))
    return replace(system, forces=tuple(new_forces), drivers=drivers), held
