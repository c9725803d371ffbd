"""Transient runs of the constrained equations with scipy's integrators: the index-1 form
in all coordinates with coordinate projection (Hairer & Wanner, Solving ODE II, VII.2).

The state is y = [q_U, q'_U, W_d, E_d] (non-driven coordinates, their rates, driver work and
dissipated energy). Its derivative solves, at any y (on the constraints or slightly off),

    M q'' + C^T lambda = rhs,   C q'' = gamma          (minimum-norm lambda; C may be
                                                        rank-deficient)

so no trial stage ever solves a loop-closure problem: nothing can close on another assembly
branch inside a step, and redundant rows or singular positions need no choice of coordinates.
After each accepted step the positions and then the velocities are moved back onto the
constraints by least-norm corrections (the drift is of the order of the local error), and the
integrator restarts from there with the step it had; a correction larger than ``jump``
(coordinate units) means the step left the constraints far behind: it is repeated with a
quarter of its size.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from pipeline.core.errors import PipelineError
from pipeline.core.progress import progress_counter
from pipeline.solver.constrained import REGULARISATION, ConstrainedSystem
from pipeline.solver.index3_compiled import CompiledStepper, stepper
from pipeline.solver.monitors import StallWatch
from pipeline.solver.outputs import OutputGrid, same_time
from pipeline.solver.result import SimulationResult

logger = logging.getLogger(__name__)

__all__ = ["run_projected"]

#: a projection correction larger than this many integration tolerances (atol + rtol |y|)
#: rejects the step: the step left the constraints far behind (near a singular position,
#: where the acceleration solve relaxes the constraint direction being lost)
DRIFT = 100.0
#: steps taken under a reduced step cap after such a rejection
CAPPED_STEPS = 20


class _Index1:
    """y' = f(t, y) of the index-1 form (see the module docstring)."""

    def __init__(self, cs: ConstrainedSystem, eps: float = REGULARISATION):
        self.cs, self.count, self.eps = cs, 0, eps
        self.nU = cs.U.size
        fast = stepper(cs)  # the compiled terms, when the force elements allow them
        self.fast = fast if isinstance(fast, CompiledStepper) else None

    def full(self, t, y):
        cs, nU = self.cs, self.nU
        q, v = np.zeros(cs.n), np.zeros(cs.n)
        q[cs.U], v[cs.U] = y[:nU], y[nU:2 * nU]
        return cs.with_drivers(t, q, v)

    def __call__(self, t, y):
        self.count += 1
        if not np.all(np.isfinite(y)):
            return np.full(y.shape, np.nan)  # rejects the step
        cs = self.cs
        q, v = self.full(t, y)
        if self.fast is not None:
            x, pd, pnc = self.fast.index1(t, q, v, self.eps)
            if not np.all(np.isfinite(x)):
                return np.full(y.shape, np.nan)
            return np.concatenate([v[cs.U], x, [pd, pnc]])
        try:
            st = cs.evaluate(t, q, v)
            qdd, lam = cs.accelerations(st, self.eps)
        except (PipelineError, ArithmeticError, ValueError, np.linalg.LinAlgError):
            return np.full(y.shape, np.nan)
        p_nc = float(st.terms.Q_nonconservative @ v)
        p_d = float(cs.driver_forces(st, qdd, lam) @ v[cs.P]) if cs.P.size else 0.0
        return np.concatenate([v[cs.U], qdd[cs.U], [p_d, -p_nc]])


def _project(cs: ConstrainedSystem, f: _Index1, t, y, unit, rtol, atol
             ) -> tuple[np.ndarray, float, float, bool]:
    """(y on the constraints, largest position correction in ``unit``, largest correction
    of q or q' relative to the integrator's tolerance atol + rtol |y|, whether it moved)."""
    if not cs.m:
        return y, 0.0, 0.0, False
    q, v = f.full(t, y)
    if f.fast is not None:
        q1, v1 = f.fast.output(t, q, v)[:2]
    else:
        st = cs.evaluate(t, q, v)
        c_err = float(np.abs(st.c).max())
        vscale = float(np.abs(v).max(initial=0.0)) + 1.0
        v_err = float(np.abs(st.C @ v).max()) / vscale
        if c_err <= 1e-12 and v_err <= 1e-12:
            return y, 0.0, 0.0, False
        q1 = cs.project_positions(t, q)
        v1 = cs.project_velocities(cs.evaluate(t, q1, v), v)
    vscale = float(np.abs(v).max(initial=0.0)) + 1.0
    if np.abs((q1 - q)[cs.U] / unit[cs.U]).max(initial=0.0) <= 1e-14 and \
            np.abs((v1 - v)[cs.U]).max(initial=0.0) <= 1e-14 * vscale:
        return y, 0.0, 0.0, False  # on the constraints already, to rounding
    nU = f.nU
    y1 = np.concatenate([q1[cs.U], v1[cs.U], y[2 * nU:]])
    moved = float(np.abs((q1 - q)[cs.U] / unit[cs.U]).max(initial=0.0))
    sc = atol + rtol * np.maximum(np.abs(y), np.abs(y1))
    drift = float(np.abs((y1 - y)[:2 * nU] / sc[:2 * nU]).max(initial=0.0))
    return y1, moved, drift, True


def run_projected(system, q0, qd0, t0, t1, te, solver_cls, name, *, rtol, atol,
                  max_step=np.inf, progress=True, max_steps=1_000_000, max_wall=None,
                  jump=0.1) -> SimulationResult:
    """Integrate from a consistent (q0, qd0) (see :func:`pipeline.solver.simulate`)."""
    tic = time.perf_counter()
    cs = ConstrainedSystem(system)
    unit = system.mechanism.coordinate_units
    f = _Index1(cs)
    q, v = cs.with_drivers(t0, q0, qd0)
    y = np.concatenate([q[cs.U], v[cs.U], [0.0, 0.0]])
    grid = OutputGrid(cs, te, None if f.fast is None else f.fast.output)
    steps = rejected = restarts = capped = 0
    msg = None
    stall = StallWatch(t1 - t0)

    def make(t, y, first_step=None, max_step=max_step):
        return solver_cls(f, t, y, t1, rtol=rtol, atol=atol, max_step=max_step,
                          first_step=first_step)

    nU = cs.U.size
    with progress_counter(te.size, "simulating", progress) as advance:
        if grid.due(t0):
            grid.record(t0, q, v, y[2 * nU:])
        try:
            solver = make(t0, y)
            while grid.k < te.size and solver.status == "running":
                if steps >= max_steps:
                    msg = f"step budget of {max_steps} steps exhausted at t = {solver.t:.6g} s"
                    break
                if max_wall is not None and time.perf_counter() - tic > max_wall:
                    msg = f"wall-time budget of {max_wall:g} s exhausted at t = {solver.t:.6g} s"
                    break
                t_prev, y_prev = solver.t, solver.y.copy()
                status = solver.step()
                if solver.status == "failed":
                    msg = f"integrator failed at t = {solver.t:.6g} s: {status}"
                    break
                h = solver.t - t_prev
                y_new, moved, drift, changed = _project(cs, f, solver.t, solver.y, unit, rtol,
                                                        atol)
                if moved > jump or drift > DRIFT:  # far off the constraints: repeat, shorter
                    rejected += 1
                    if 0.25 * h < 1e-10 * max(t1 - t0, abs(t_prev)):
                        msg = (f"the loops cannot be followed at t = {t_prev:.6g} s: even short "
                               f"steps drift {drift:.3g} tolerances off them (a singular "
                               "position?); method='generalized_alpha' passes such places")
                        break
                    solver = make(t_prev, y_prev, first_step=0.25 * h, max_step=0.5 * h)
                    capped = CAPPED_STEPS
                    continue
                dense = solver.dense_output() if grid.due(solver.t) else None
                _fill(grid, f, dense, t_prev, solver.t, y_new)
                advance(grid.k)
                steps += 1
                msg = stall(solver.t)
                if msg:
                    break
                capped = max(capped - 1, 0)
                if (changed or capped == 1) and solver.status == "running":
                    restarts += 1
                    # continue with the step the integrator proposed next (its h_abs)
                    h_next = float(getattr(solver, "h_abs", h) or h)
                    solver = make(solver.t, y_new, first_step=min(h_next, t1 - solver.t),
                                  max_step=max_step if capped <= 1 else h)
        except (PipelineError, np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
            msg = f"integration failed at t = {solver.t:.6g} s: {exc}"
    total = time.perf_counter() - tic
    if msg:
        logger.warning("simulation: %s", msg)
    stats = {"rejected": rejected, "restarts": restarts, "evaluations": f.count}
    return grid.result(msg, steps, f.count, total, name, stats)


def _fill(grid: OutputGrid, f: _Index1, dense, t0, t1, y1):
    """Record the outputs in (t0, t1]: from the step's dense output (projected by the grid),
    the step end itself from its projected state."""
    nU = f.nU
    while grid.due(t1):
        tk = grid.te[grid.k]
        y = y1 if abs(tk - t1) <= same_time(t1) else dense(tk)
        q, v = f.full(tk, y)
        grid.record(tk, q, v, y[2 * nU:])
