"""Transient runs of the constrained equations (the DAE, DESIGN §4 (b)) by index-3
generalised-alpha steps (:mod:`pipeline.solver.index3`).

Step size: fixed (``step`` given: every step has that size, shortened only to end on t1 or
halved after a rejected step) or adaptive from the local error estimate of the position update,
e = (beta - 1/6) h^2 (q''_{n+1} - q''_n) (Zienkiewicz & Xie's estimate for Newmark-type
methods), kept below atol * unit + rtol * |q| in the RMS norm. A step is rejected and retried
with half its size when Newton fails, a state cannot be evaluated, or Newton converges more
than ``jump`` away from the prediction (another assembly branch; closed loops only).

Outputs: at each requested time between two step ends the positions and velocities are
interpolated (cubic Hermite), projected onto the constraints (least-norm changes of the
non-driven coordinates; the closure then holds to 1e-12 at every output), and the
accelerations and multipliers are those of that state (the index-1 solve; minimum-norm
multipliers where closure rows are redundant). The energy removed by damping and supplied by
the drivers is integrated with the motion (trapezoidal rule over the steps).
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np

from pipeline.core.errors import PipelineError
from pipeline.core.progress import progress_counter
from pipeline.solver.constrained import ConstrainedSystem
from pipeline.solver.generalized_alpha import first_order_coefficients
from pipeline.solver.index3_compiled import stepper as make_stepper
from pipeline.solver.monitors import StallWatch
from pipeline.solver.outputs import OutputGrid, same_time
from pipeline.solver.result import SimulationResult

logger = logging.getLogger(__name__)

__all__ = ["run_dae"]


def run_dae(system, q0, qd0, t0, t1, te, *, rtol, atol, step=None, rho_inf=0.8,
            max_step=np.inf, progress=True, max_steps=1_000_000, max_wall=None,
            jump=0.1, estimate: bool = True, positions_only: bool = False
            ) -> SimulationResult:
    """Integrate from a consistent (q0, qd0) (see :func:`pipeline.solver.simulate`); a
    fixed-step run is run again at twice the step to estimate its error (``estimate``,
    :mod:`pipeline.solver.step_error`), recording its positions only
    (``positions_only``: OutputGrid)."""
    tic = time.perf_counter()
    cs = ConstrainedSystem(system)
    unit = system.mechanism.coordinate_units
    run = _Run(cs, unit, t0, t1, rtol, atol, step, max_step, max_steps, max_wall, tic)
    # the run at twice the step (positions only) is a check: the run said it already
    stepper = dae_stepper(cs, rtol, atol, step, rho_inf, jump, warn=not positions_only)
    run.state_gamma = first_order_coefficients(rho_inf)[1]
    q, v = cs.with_drivers(t0, q0, qd0)
    grid = OutputGrid(cs, te, getattr(stepper, "output", None), positions_only)
    with progress_counter(te.size, "simulating", progress) as advance:
        _, _, msg = march_guarded(run, stepper, (t0, q, v), np.zeros(2), grid, advance)
    total = time.perf_counter() - tic
    if msg:
        logger.warning("simulation: %s", msg)
    r = grid.result(msg, run.steps, stepper.evaluations, total, "generalized_alpha",
                    run.stats(stepper))
    if step and estimate and not msg:  # a fixed step has no error control: estimate it
        from pipeline.solver.step_error import fixed_step_error

        tic = time.perf_counter()
        coarse = run_dae(system, q0, qd0, t0, t1, r.t, rtol=rtol, atol=atol, step=2 * step,
                         rho_inf=rho_inf, max_step=max_step, progress=False, jump=jump,
                         max_steps=max_steps, max_wall=max_wall, estimate=False,
                         positions_only=True)
        est = fixed_step_error(r, coarse, cs.U, rtol, atol, unit,
                               system.mechanism.modal_index, system.state_scales())
        est["error_seconds"] = time.perf_counter() - tic
        r = replace(r, step_stats={**r.step_stats, **est})
    return r


def dae_stepper(cs: ConstrainedSystem, rtol, atol, step, rho_inf, jump=0.1, warn=True):
    """The generalised-alpha stepper of ``cs`` (compiled where the force elements allow;
    ``warn``: log when not) with the Newton tolerances that keep a fixed-step or an
    adaptive run at its order."""
    if not cs.system.mechanism.topology.loops:
        jump = np.inf  # no closure, no branch to leave: a stiff mode may move far in a step
    # Newton errors add up over the steps like truncation errors: well below the local
    # error (adaptive), or, with a fixed step, below both the tolerance (which now sets the
    # error accepted, see step_error) and 1e-8 relative, or the method loses its order (a
    # four-bar at 1 ms: 34x the error with Newton stopped at rtol)
    if step:
        newton_rtol, newton_atol = min(1e-2 * rtol, 1e-8), min(1e-2 * atol, 1e-10)
    else:
        newton_rtol, newton_atol = 0.1 * rtol, 0.1 * atol
    return make_stepper(cs, warn, rho_inf=rho_inf, newton_rtol=newton_rtol,
                        newton_atol=newton_atol, closure_tol=1e-10,
                        unit=cs.system.mechanism.coordinate_units, jump=jump)


def march_guarded(run, stepper, s, work, grid, advance):
    """:meth:`_Run.march` from the step state s (or a start (t, q, v)), a state the
    equations cannot be solved at (a singular start) turned into the failure message:
    (state, work, message or None)."""
    try:
        if isinstance(s, tuple):
            s = stepper.start(*s)
        return run.march(stepper, s, work, grid, advance)
    except (PipelineError, np.linalg.LinAlgError, ArithmeticError, ValueError) as exc:
        from pipeline.kinematics.joints import gimbal_lock_note

        system = run.cs.system
        here = s[:2] if isinstance(s, tuple) else (s.t, s.q)
        t_fail, q_fail = grid.rows[-1][:2] if grid.rows else here
        return s, work, (f"integration failed after t = {t_fail:.6g} s: {exc}"
                         + gimbal_lock_note(system.mechanism, q_fail))


#: the most fixed steps one compiled call takes (outputs are recorded inside it)
STRETCH = 500


class _Run:
    """Step-size control and budgets of one run."""

    def __init__(self, cs, unit, t0, t1, rtol, atol, step, max_step, max_steps, max_wall, tic):
        self.cs, self.unit, self.t1 = cs, unit, t1
        self.rtol, self.atol, self.step = rtol, atol, step
        self.max_step, self.max_steps, self.max_wall, self.tic = max_step, max_steps, max_wall, tic
        self.span = t1 - t0
        self.h = min(float(step) if step else 1e-3 * self.span, max_step)
        self.nominal = self.h
        self.steps = self.rejected = 0
        self.stall = StallWatch(self.span)
        self.hmin, self.hmax = np.inf, 0.0
        self.impulses = 0  # drivers' rate jumps passed
        # the force elements' own states: their scales and their method's gamma
        self.zscale = cs.system.state_scales()
        self.state_gamma = 0.0

    def _budget(self, t) -> str | None:
        if self.steps >= self.max_steps:
            return f"step budget of {self.max_steps} steps exhausted at t = {t:.6g} s"
        if self.max_wall is not None and time.perf_counter() - self.tic > self.max_wall:
            return f"wall-time budget of {self.max_wall:g} s exhausted at t = {t:.6g} s"
        return None

    def _too_small(self, h, t) -> bool:
        return h < 1e-10 * max(self.span, abs(t)) or (self.step and h < 1e-6 * self.step)

    def _error(self, s0, s1, h, beta) -> float:
        """RMS of the local error estimate over its tolerance: positions', and the force
        elements' own states' ((gamma_z - 1/2) h (z'_1 - z'_0), the same order)."""
        U = self.cs.U
        e = (beta - 1.0 / 6.0) * h * h * (s1.qdd - s0.qdd)[U]
        scale = self.atol * self.unit[U] + self.rtol * np.maximum(np.abs(s0.q[U]),
                                                                  np.abs(s1.q[U]))
        if s1.z.size:
            gz = self.state_gamma
            e = np.concatenate([e, (gz - 0.5) * h * (s1.zd - s0.zd)])
            scale = np.concatenate([scale, self.atol * self.zscale + self.rtol * np.maximum(
                np.abs(s0.z), np.abs(s1.z))])
        return float(np.sqrt(np.mean((e / scale) ** 2))) if e.size else 0.0

    def stats(self, stepper) -> dict:
        """The step statistics of the run so far (SimulationResult.step_stats)."""
        return {"rejected": self.rejected, "h_min": self.hmin if self.steps else 0.0,
                "h_max": self.hmax, "evaluations": stepper.evaluations,
                "jacobians": stepper.jacobians, "impulses": self.impulses}

    def march(self, stepper, s, work, grid, advance):
        """Step from s to t1, recording outputs; work (2,): the driver work and dissipated
        energy at s, J. Returns (state, work, failure message or None).

        A step ends on every break of the drivers (a table's knot, a ramp's start), and the
        method starts afresh there from the velocities just after it (with the impulse a
        jump of a driven rate needs, ConstrainedSystem.across_break): stepping across, its
        acceleration-like variable would lag the jump and the run lose its order."""
        end = self.t1
        try:
            for tb in self.cs.breaks(s.t, end):
                self.t1 = self.cs.left_of = float(tb)
                s, work, msg = self._segment(stepper, s, work, grid, advance)
                self.cs.left_of = None
                if msg:
                    return s, work, msg
                v, dw = self.cs.across_break(float(tb), s.q, s.v)
                if dw:
                    if not self.impulses:
                        logger.info("a driven rate jumps at t = %.6g s: the machine takes "
                                    "the impulse an ideal prescribed motion needs (%.4g J); "
                                    "a pchip or spline table moves it smoothly", tb, dw)
                    self.impulses += 1
                s = stepper.start(float(tb), s.q, v, *((s.z,) if s.z.size else ()))
                work = work + np.array([dw, 0.0])
            self.t1 = end
            return self._segment(stepper, s, work, grid, advance)
        finally:
            self.t1, self.cs.left_of = end, None

    def _segment(self, stepper, s, work, grid, advance):
        """:meth:`march` to t1 without a break in between."""
        if grid.due(s.t):
            grid.record(s.t, s.q, s.v, work, s.z)
        while s.t < self.t1 - same_time(self.t1):
            msg = self._budget(s.t)
            if msg:
                return s, work, msg
            if self.step and self.h == self.nominal and hasattr(stepper, "march"):
                s, work, msg = self._stretch(stepper, s, grid, advance, work)
                if msg:
                    return s, work, msg
                continue
            h = min(self.h, self.t1 - s.t)
            if self.t1 - (s.t + h) < 1e-3 * h:  # no sliver of a last step
                h = self.t1 - s.t
            out = stepper.step(s, h)
            if out.state is None:
                self.rejected += 1
                stepper.reset()
                self.h = 0.5 * h
                if self._too_small(self.h, s.t):
                    return s, work, (f"step size collapsed to {self.h:.3g} s at t = "
                                     f"{s.t:.6g} s: " + _FAILURES[out.why](out))
                continue
            s1 = out.state
            if not self.step:
                err = self._error(s, s1, h, stepper.beta)
                factor = 4.0 if err == 0 else min(4.0, max(0.2, 0.9 * err ** (-1.0 / 3.0)))
                if err > 1.0:
                    self.rejected += 1
                    self.h = h * min(factor, 0.9)
                    if self._too_small(self.h, s.t):
                        return s, work, (f"step size collapsed to {self.h:.3g} s at t = "
                                         f"{s.t:.6g} s (error control)")
                    continue
                self.h = min(h * factor, self.max_step)
            else:  # back towards the user's step after a halved one
                self.h = min(2.0 * h, self.nominal)
            work1 = work + 0.5 * h * (s.powers + s1.powers)
            grid.fill_hermite(s.t, s.q, s.v, work, s1.t, s1.q, s1.v, work1,
                              (s.z, s.zd, s1.z, s1.zd) if s.z.size else None)
            advance(grid.k)
            s, work = s1, work1
            self.steps += 1
            self.hmin, self.hmax = min(self.hmin, h), max(self.hmax, h)
            msg = self.stall(s.t)
            if msg:
                return s, work, msg
        return s, work, None


    def _stretch(self, stepper, s, grid, advance, work):
        """Fixed steps in one compiled call, recording the outputs they pass, up to t1 or
        :data:`STRETCH` steps (then the budgets, the stall watch and the progress bar
        have their say); the step that fails (if one does) is retried by the caller at
        half the size. Returns (state, work, message or None)."""
        h = self.nominal
        count = max(1, min(STRETCH, int(np.ceil((self.t1 - s.t) / h - 1e-9))))
        while count > 1 and s.t + count * h > self.t1 + same_time(self.t1):
            count -= 1
        count = min(count, self.max_steps - self.steps)
        if s.t + count * h > self.t1 + same_time(self.t1):  # only a shortened last step
            self.h = self.t1 - s.t
            return s, work, None
        done, why, _, last, work1 = stepper.march(s, h, count, work, grid)
        if done:
            advance(grid.k)
            s, work = last, work1
            self.steps += done
            self.hmin, self.hmax = min(self.hmin, h), max(self.hmax, h)
            msg = self.stall(s.t)
            if msg:
                return s, work, msg
        if why:
            self.rejected += 1
            stepper.reset()
            self.h = 0.5 * h
        return s, work, None


_FAILURES = {
    "jump": lambda o: (f"the closed configuration left the predicted one by {o.correction:.3g} "
                       "(another assembly branch?)"),
    "newton": lambda o: "Newton did not converge",
    "evaluation": lambda o: "the equations could not be evaluated",
}
