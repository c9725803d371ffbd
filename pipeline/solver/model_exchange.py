"""A model-exchange FMU (FMI 2 or FMI 3) integrated by this master: its continuous states
over each macro step with its inputs held, its state and time events located and handled
on the way (the FMI standard's model-exchange loop, for one FMU beside the machine).

Over [t, t + H] the states x' = f(t, x) are integrated by scipy's LSODA (rtol 1e-9: the
FMU's own error far below the coupling's) in segments that end at

- a **state event**: one of the FMU's event indicators z_i(t, x) changes sign. The signs
  are compared at LSODA's accepted steps; a change is then located on its dense output by
  bisection to 1e-13 of the time's scale (an event time that is not the exact root by
  more than that, plus LSODA's error), and the segment ends just past the root, where
  the sign has changed (an FMU that decides its mode by the sign sees the crossing). Two
  crossings of one indicator inside one accepted step are not seen (as in any such
  integrator: the step is bounded by the dynamics, not by the indicators);
- a **time event** the FMU announced (``nextEventTime``), or a **tick** of one of its
  periodic input clocks (FMI 3, ``intervalVariability="constant"``: at shift + k interval
  from the start), where the clock is activated (``setClock``) and the FMU's clocked
  inputs are set (the machine's signals as held over the macro step) before its discrete
  states are updated, its clocked outputs read after (and held until the next tick);
- t + H, where the FMU may still ask for an event (``completedIntegratorStep``).

A time event or tick at t + H itself is taken at the start of the next macro step, with
the inputs of that communication point (the machine's state there is not known before).

At an event the FMU is put in Event Mode, its discrete states are iterated until they
settle (``newDiscreteStates`` / ``updateDiscreteStates``), and it returns to
Continuous-Time Mode with its (possibly reset) states and its next time event. An input
set at a communication point that changes an indicator's sign is an event there, before
the step. An FMU that asks to terminate, or whose events do not settle (100 iterations,
or 1000 events in one macro step: chattering), fails the step with one line naming it.
"""

from __future__ import annotations

import ctypes

import numpy as np

__all__ = ["ExchangeFailed", "ModelExchange"]

#: event iterations at one instant, and events within one macro step, before giving up
MAX_ITERATIONS, MAX_EVENTS = 100, 1000


class ExchangeFailed(Exception):
    """The FMU failed, asked to terminate or chattered: one line naming it and when."""


class ModelExchange:
    """The continuous-time side of a model-exchange FMU (an fmpy ``FMU2Model`` or
    ``FMU3Model`` already initialised, in Event Mode): ``nx`` states, ``nz`` event
    indicators; ``where`` names it in messages."""

    def __init__(self, slave, fmi3: bool, nx: int, nz: int, where: str, t0: float,
                 clocks=None, before_tick=None, after_tick=None):
        """``clocks``: {value reference: (interval, shift), s} of its periodic input clocks;
        ``before_tick(t)`` sets its clocked inputs at a tick (in Event Mode, the clocks
        active), ``after_tick()`` reads its clocked outputs after it."""
        self.slave, self.fmi3, self.where = slave, fmi3, where
        self.nx, self.nz = int(nx), int(nz)
        self.clocks = dict(clocks or {})
        self.ticks = {vr: 0 for vr in self.clocks}  # each clock's next tick's index
        self.t0 = float(t0)
        self.before_tick, self.after_tick = before_tick, after_tick
        self._x = (ctypes.c_double * max(self.nx, 1))()
        self._dx = (ctypes.c_double * max(self.nx, 1))()
        self._z = (ctypes.c_double * max(self.nz, 1))()
        self.next_time: float | None = None
        self.events = 0  # events handled, over the run
        self._settle(t0, "its initialisation")
        self.x = self._states()
        self.signs = self._signs(t0, self.x)

    # ------------------------------------------------------------------ FMU calls
    def _states(self) -> np.ndarray:
        if self.nx:
            self.slave.getContinuousStates(self._x, self.nx)
        return np.array(self._x[:self.nx])

    def _put(self, t: float, x: np.ndarray) -> None:
        self.slave.setTime(t)
        if self.nx:
            self._x[:self.nx] = x
            self.slave.setContinuousStates(self._x, self.nx)

    def derivatives(self, t: float, x: np.ndarray) -> np.ndarray:
        """x' (nx,) at (t, x)."""
        self._put(t, x)
        if self.fmi3:
            self.slave.getContinuousStateDerivatives(self._dx, self.nx)
        else:
            self.slave.getDerivatives(self._dx, self.nx)
        return np.array(self._dx[:self.nx])

    def indicators(self, t: float, x: np.ndarray) -> np.ndarray:
        """The event indicators z (nz,) at (t, x)."""
        self._put(t, x)
        if self.nz:
            self.slave.getEventIndicators(self._z, self.nz)
        return np.array(self._z[:self.nz])

    def _signs(self, t: float, x: np.ndarray) -> np.ndarray:
        return np.sign(self.indicators(t, x)) if self.nz else np.zeros(0)

    def _settle(self, t: float, when: str) -> None:
        """Event Mode -> the discrete states iterated until they settle -> Continuous-Time
        Mode; the FMU's next time event kept."""
        update = self.slave.updateDiscreteStates if self.fmi3 else self.slave.newDiscreteStates
        for _ in range(MAX_ITERATIONS):
            need, terminate, _, _, timed, at = update()
            if terminate:
                raise ExchangeFailed(f"{self.where}: asked to terminate at {when} "
                                     f"(t = {t:.6g} s)")
            if not need:
                break
        else:
            raise ExchangeFailed(f"{self.where}: its discrete states did not settle at "
                                 f"{when} (t = {t:.6g} s, {MAX_ITERATIONS} event iterations)")
        self.next_time = float(at) if timed else None
        self.slave.enterContinuousTimeMode()

    def _tick_time(self, vr: int) -> float:
        interval, shift = self.clocks[vr]
        return self.t0 + shift + self.ticks[vr] * interval

    def _due(self) -> float | None:
        """The next time event or tick, s (None: none)."""
        times = [self._tick_time(vr) for vr in self.clocks]
        if self.next_time is not None:
            times.append(self.next_time)
        return min(times) if times else None

    def _event(self, t: float, x: np.ndarray, ticking=()) -> None:
        """The FMU's event at (t, x), its clocks ``ticking`` (value references) active;
        its states and indicator signs after it."""
        self._put(t, x)
        self.slave.enterEventMode()
        if ticking:
            self.slave.setClock(list(ticking), [True] * len(ticking))
            if self.before_tick is not None:
                self.before_tick(t)
        self._settle(t, "an event")
        if ticking:
            if self.after_tick is not None:
                self.after_tick()
            for vr in ticking:
                self.ticks[vr] += 1
        self.events += 1
        self.x = self._states()
        self.signs = self._signs(t, self.x)

    # ------------------------------------------------------------------ the loop
    def inputs_set(self, t: float) -> None:
        """Its inputs were set at t: an indicator whose sign they changed is an event."""
        if self.nz:
            signs = self._signs(t, self.x)
            if np.any((signs != self.signs) & (self.signs != 0)):
                self._event(t, self.x)
            else:
                self.signs = np.where(self.signs == 0, signs, self.signs)

    def advance(self, t: float, h: float) -> None:
        """Its states from t to t + h, its inputs held, its events handled on the way."""
        end = t + h
        eps = 1e-12 * max(1.0, abs(end))  # "at" a time: a tick's k interval is rounded
        tn, count = t, 0
        while True:
            due = self._due()
            timed = due is not None and due < end - eps  # (at t + H: the next step's)
            stop = max(due, tn) if timed else end
            x, te = self._segment(tn, stop, self.x)
            tn = stop if te is None else te
            self._put(tn, x)
            ask, terminate = self.slave.completedIntegratorStep()
            if terminate:
                raise ExchangeFailed(f"{self.where}: asked to terminate at t = {tn:.6g} s")
            if te is not None or timed or ask:
                ticking = [vr for vr in self.clocks if self._tick_time(vr) <= tn + eps] \
                    if te is None else []
                self._event(tn, x, ticking)
                count += 1
                if count > MAX_EVENTS:
                    raise ExchangeFailed(
                        f"{self.where}: {MAX_EVENTS} events between t = {t:.6g} and "
                        f"{end:.6g} s (chattering: an indicator that its own event does not "
                        "move away from zero)")
            else:
                self.x = x
            if tn >= end - eps:
                self.slave.setTime(end)
                return

    def _segment(self, t0: float, t1: float, x0: np.ndarray):
        """(x, None) at t1, or (x, te) just past the first state event te in (t0, t1]."""
        if t1 <= t0:
            return x0, None
        if self.nx:
            from scipy.integrate import solve_ivp

            try:
                sol = solve_ivp(self.derivatives, (t0, t1), x0, method="LSODA", rtol=1e-9,
                                atol=1e-12 * np.maximum(1.0, np.abs(x0)),
                                dense_output=bool(self.nz))
            except Exception as exc:  # noqa: BLE001 - the FMU failed an evaluation
                raise ExchangeFailed(f"{self.where}: its states from t = {t0:.6g} s could "
                                     f"not be integrated ({exc})") from None
            if not sol.success:
                raise ExchangeFailed(f"{self.where}: its states from t = {t0:.6g} s could "
                                     f"not be integrated ({sol.message})")
            ts, xs = sol.t, sol.y.T

            def state(t):
                return sol.sol(t)
        else:  # indicators of time and inputs only
            ts, xs = np.array([t0, t1]), np.zeros((2, 0))

            def state(t):
                return x0
        if not self.nz:
            return xs[-1], None
        signs = self.signs.copy()
        for k in range(1, ts.size):
            now = np.sign(self.indicators(ts[k], xs[k]))
            crossed = (now != signs) & (signs != 0)
            if crossed.any():
                te = min(self._root(i, ts[k - 1], ts[k], signs[i], state)
                         for i in np.flatnonzero(crossed))
                return state(te), te
            signs = np.where(signs == 0, now, signs)  # an indicator leaving its root
        self.signs = signs
        return xs[-1], None

    def _root(self, i: int, a: float, b: float, before: float, state) -> float:
        """The time just past indicator i's sign change from ``before`` in (a, b]: b of a
        bisection bracket 1e-13 of the time's scale wide."""
        tol = 1e-13 * max(1.0, abs(b))
        while b - a > tol:
            m = 0.5 * (a + b)
            if np.sign(self.indicators(m, state(m))[i]) == before:
                a = m
            else:
                b = m
        return b
