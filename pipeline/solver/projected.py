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

A singular position -- the constraint rows lose rank, the index-1 solve relaxes the
direction being lost, and the scipy method's steps collapse (from 0.1 s to 1e-7 s on the
parallelogram) or drift off the constraints -- is crossed by design, not left to round-off
(which used to decide whether the run passed it): when the accepted step falls below
:data:`COLLAPSE` of the run's recent steps while the Jacobian's smallest kept singular
value is below :data:`NEAR_SINGULAR` of its largest, or after :data:`BRIDGE_AFTER`
rejections at one place, index-3 generalised-alpha steps (:mod:`pipeline.solver.index3`),
which hold the constraints themselves and follow the branch by continuity, carry the run
over it: :data:`BRIDGE_STEPS` steps of rtol^(1/3) times the recent step (their local error
then about the tolerance; much shorter steps would leave the index-3 Newton matrix
ill-conditioned, as 1/h^2), Newton at a hundredth of the tolerance. The scipy method
resumes from their end.
"""

from __future__ import annotations

import logging
import time
from collections import deque

import numpy as np

from pipeline.core.errors import PipelineError
from pipeline.core.progress import progress_counter
from pipeline.kinematics.closure import closure
from pipeline.solver.constrained import REGULARISATION, ConstrainedSystem
from pipeline.solver.dae_kernels import hermite
from pipeline.solver.index3_compiled import stepper
from pipeline.solver.index3_compiled import stepper as make_stepper
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
#: rejections at one place before index-3 steps carry the run over it
BRIDGE_AFTER = 3
#: an accepted step below this share of the largest of the last :data:`RECENT` ones has
#: collapsed
COLLAPSE = 1e-2
RECENT = 20
#: the Jacobian's smallest kept singular value (its rank at the start) below this share of
#: its largest: near a singular position
NEAR_SINGULAR = 1e-2
#: index-3 steps of such a bridge, each half the last step accepted before it
BRIDGE_STEPS = 32


class _Index1:
    """y' = f(t, y) of the index-1 form (see the module docstring)."""

    def __init__(self, cs: ConstrainedSystem, eps: float = REGULARISATION):
        self.cs, self.count, self.eps = cs, 0, eps
        self.nU = cs.U.size
        self.fast = stepper(cs)  # the compiled terms

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
        x, pd, pnc = self.fast.index1(t, q, v, self.eps)
        if not np.all(np.isfinite(x)):
            return np.full(y.shape, np.nan)
        return np.concatenate([v[cs.U], x, [pd, pnc]])


def _project(cs: ConstrainedSystem, f: _Index1, t, y, unit, rtol, atol
             ) -> tuple[np.ndarray, float, float, bool]:
    """(y on the constraints, largest position correction in ``unit``, largest correction
    of q or q' relative to the integrator's tolerance atol + rtol |y|, whether it moved)."""
    if not cs.m:
        return y, 0.0, 0.0, False
    q, v = f.full(t, y)
    q1, v1 = f.fast.output(t, q, v)[:2]
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
    grid = OutputGrid(cs, te, f.fast.output)
    steps = rejected = restarts = capped = 0
    msg = None
    stall = StallWatch(t1 - t0)

    def make(t, y, first_step=None, max_step=max_step):
        # up to the drivers' next break, where the run starts afresh (_Run.march in dae)
        cs.left_of = cs.next_break(t, t1)
        bound = t1 if cs.left_of is None else cs.left_of
        if first_step is not None:
            first_step = min(first_step, bound - t)
        return solver_cls(f, t, y, bound, rtol=rtol, atol=atol, max_step=max_step,
                          first_step=first_step)

    def across(t, y):
        """A solver started afresh after the break reached at (t, y), with its impulse."""
        q, v = f.full(t, y)
        cs.left_of = None
        v, dw = cs.across_break(t, q, v)
        return make(t, np.concatenate([q[cs.U], v[cs.U], y[2 * nU:] + np.array([dw, 0.0])]))

    nU = cs.U.size
    stuck, bridges, since_bridge = 0, 0, BRIDGE_AFTER
    recent: deque = deque(maxlen=RECENT)
    rank0 = _rank(cs, f, t0, y)

    def cross(t, y, h):
        """Index-3 steps from (t, y) over a singular place; (why they failed or "", the
        scipy solver resumed after them, or None at t1)."""
        nonlocal steps, bridges, since_bridge
        h_b = max(recent, default=h) * rtol ** (1.0 / 3.0)
        bound = solver.t_bound
        bridged = _bridge(cs, f, grid, t, y, h_b, bound, rtol, atol, unit, jump)
        if isinstance(bridged, str):
            return bridged, None
        t_b, y_b, n_b = bridged
        advance(grid.k)
        steps, bridges, since_bridge = steps + n_b, bridges + 1, 0
        recent.clear()
        if t_b >= t1 - same_time(t1):
            return "", None
        if t_b >= bound - same_time(bound):
            return "", across(t_b, y_b)
        return "", make(t_b, y_b, first_step=min(h_b, t1 - t_b))

    with progress_counter(te.size, "simulating", progress) as advance:
        if grid.due(t0):
            grid.record(t0, q, v, y[2 * nU:])
        try:
            solver = make(t0, y)
            while grid.k < te.size and solver.status != "failed":
                if solver.status == "finished":
                    if solver.t >= t1 - same_time(t1):
                        break
                    solver = across(solver.t_bound, solver.y)
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
                    stuck += 1
                    if stuck >= BRIDGE_AFTER or 0.25 * h < 1e-10 * max(t1 - t0, abs(t_prev)):
                        if since_bridge < BRIDGE_AFTER:  # scipy's steps fail right after one
                            msg = (f"the loops cannot be followed at t = {t_prev:.6g} s: even "
                                   f"short steps drift {drift:.3g} tolerances off them (a "
                                   "singular position at a very tight tolerance?); "
                                   "method='generalized_alpha' passes such places")
                            break
                        why, solver = cross(t_prev, y_prev, h)
                        if why or solver is None:
                            msg = (f"the loops cannot be followed at t = {t_prev:.6g} s: "
                                   f"steps drift {drift:.3g} tolerances off them and "
                                   f"index-3 steps failed there too ({why})") if why else None
                            break
                        continue
                    solver = make(t_prev, y_prev, first_step=0.25 * h, max_step=0.5 * h)
                    capped = CAPPED_STEPS
                    continue
                stuck = 0
                since_bridge += 1
                inside = grid.due(solver.t - same_time(solver.t))
                if inside and rank0 and _dips_inside(cs, f, t_prev, y_prev, solver.t, y_new,
                                                     rank0):
                    _index3_outputs(cs, f, grid, t_prev, y_prev, solver.t, rtol, atol, unit,
                                    jump)
                dense = solver.dense_output() if grid.due(solver.t) else None
                _fill(grid, f, dense, t_prev, solver.t, y_new)
                advance(grid.k)
                steps += 1
                if rank0 and recent and h < COLLAPSE * max(recent) and \
                        solver.t < t1 - same_time(t1) and \
                        _near_singular(cs, f, solver.t, y_new, rank0):
                    why, solver = cross(solver.t, y_new, h)
                    if why or solver is None:
                        msg = (f"the run cannot pass the singular position near t = "
                               f"{t_prev:.6g} s: index-3 steps failed there ({why})"
                               ) if why else None
                        break
                    continue
                recent.append(h)
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
            from pipeline.kinematics.joints import gimbal_lock_note

            msg = (f"integration failed at t = {solver.t:.6g} s: {exc}"
                   + gimbal_lock_note(system.mechanism, f.full(solver.t, solver.y)[0]))
        finally:
            cs.left_of = None
    total = time.perf_counter() - tic
    if msg:
        logger.warning("simulation: %s", msg)
    stats = {"rejected": rejected, "restarts": restarts, "evaluations": f.count,
             "bridges": bridges}
    return grid.result(msg, steps, f.count, total, name, stats)


def _jacobian_singular_values(cs: ConstrainedSystem, f: _Index1, t, y) -> np.ndarray:
    """Singular values of the closure Jacobian's integrated columns at (t, y) (weighted
    rows, as ``cs.evaluate(...).C``; the positions alone decide them), largest first."""
    J = closure(cs.system.mechanism, f.full(t, y)[0]).J
    return np.linalg.svd(cs.w[:, None] * J[:, cs.U], compute_uv=False)


def _rank(cs: ConstrainedSystem, f: _Index1, t, y) -> int:
    """Rank of the closure Jacobian's integrated columns at (t, y) (0 without loops)."""
    if not cs.m:
        return 0
    s = _jacobian_singular_values(cs, f, t, y)
    return int(np.sum(s > 1e-8 * s[0])) if s.size and s[0] > 0 else 0


def _near_singular(cs: ConstrainedSystem, f: _Index1, t, y, rank0: int) -> bool:
    """The Jacobian's singular value number ``rank0`` is below :data:`NEAR_SINGULAR` of
    its largest: a singular position is near (redundant rows, lost everywhere, do not
    count)."""
    s = _jacobian_singular_values(cs, f, t, y)
    return s.size >= rank0 and s[rank0 - 1] < NEAR_SINGULAR * s[0]


def _ratio(cs: ConstrainedSystem, f: _Index1, t, y, rank0: int) -> float:
    """Singular value number ``rank0`` of the closure Jacobian's integrated columns over
    its largest at (t, y)."""
    s = _jacobian_singular_values(cs, f, t, y)
    return s[rank0 - 1] / s[0] if s.size >= rank0 and s[0] > 0 else 0.0


def _dips_inside(cs: ConstrainedSystem, f: _Index1, t0, y0, t1, y1, rank0: int,
                 samples: int = 8) -> bool:
    """Whether the Jacobian's conditioning (:func:`_ratio`) somewhere inside the step
    (``samples`` - 1 points of the cubic Hermite positions) is below :data:`NEAR_SINGULAR`
    and under half its value at both ends: the step passed over a near-singular place
    rather than ending near one."""
    nU = f.nU
    h = t1 - t0
    q0, v0, q1, v1 = y0[:nU], y0[nU:2 * nU], y1[:nU], y1[nU:2 * nU]
    ends = min(_ratio(cs, f, t0, y0, rank0), _ratio(cs, f, t1, y1, rank0))
    y = y1.copy()
    for k in range(1, samples):
        s = k / samples
        y[:nU] = hermite(q0, v0, q1, v1, h, s)[0]
        r = _ratio(cs, f, t0 + s * h, y, rank0)
        if r < NEAR_SINGULAR and r < 0.5 * ends:
            return True
    return False


def _index3_outputs(cs: ConstrainedSystem, f: _Index1, grid: OutputGrid, t0, y0, t1, rtol,
                    atol, unit, jump) -> None:
    """Record the outputs inside a step (t0, t1) that passed over a near-singular place from
    index-3 steps of rtol^(1/3) of it (at least 8) rather than from the step's dense output.

    Why: the dense output there is off the constraints, and moving it back onto them near a
    singular position shifts it along the branch by that offset over the small singular value
    (2e-5 rad at rtol 1e-8 on the parallelogram, whose step ends are right to 1e-7). If the
    index-3 steps fail, they record nothing and the dense output records them as before."""
    n = max(8, int(np.ceil(rtol ** (-1.0 / 3.0))))
    _bridge(cs, f, grid, t0, y0, (t1 - t0) / n, t1 - same_time(t1), rtol, atol, unit, jump,
            n_steps=n)


def _bridge(cs: ConstrainedSystem, f: _Index1, grid: OutputGrid, t, y, h, t1, rtol, atol,
            unit, jump, n_steps: int = BRIDGE_STEPS) -> tuple[float, np.ndarray, int] | str:
    """Carry the run from (t, y) over a place the projected steps cannot follow with
    ``n_steps`` index-3 generalised-alpha steps of size ``h`` (halved up to three times if
    Newton fails), recording the outputs on the way; returns (t, y, steps)
    at the end, or why it failed."""
    nU = f.nU
    q, v = f.full(t, y)
    ga = make_stepper(cs, newton_rtol=1e-2 * rtol, newton_atol=1e-2 * atol,
                      closure_tol=1e-10, unit=unit, jump=jump)
    why = ""
    for _ in range(4):
        s, work = ga.start(t, q, v), np.array(y[2 * nU:], dtype=float)
        path = []
        for _ in range(n_steps):
            hk = min(h, t1 - s.t)
            out = ga.step(s, hk)
            if out.state is None:
                why = f"{out.why} at t = {s.t:.6g} s"
                break
            work1 = work + 0.5 * hk * (s.powers + out.state.powers)
            path.append((s, work, out.state, work1))
            s, work = out.state, work1
            if s.t >= t1 - same_time(t1):
                break
        else:
            why = ""
        if not why or s.t >= t1 - same_time(t1):
            for s0, w0, s1, w1 in path:
                grid.fill_hermite(s0.t, s0.q, s0.v, w0, s1.t, s1.q, s1.v, w1)
            return s.t, np.concatenate([s.q[cs.U], s.v[cs.U], work]), len(path)
        h *= 0.5
        ga.reset()
    return why


def _fill(grid: OutputGrid, f: _Index1, dense, t0, t1, y1):
    """Record the outputs in (t0, t1]: from the step's dense output (projected by the grid),
    the step end itself from its projected state."""
    nU = f.nU
    while grid.due(t1):
        tk = grid.te[grid.k]
        y = y1 if abs(tk - t1) <= same_time(t1) else dense(tk)
        q, v = f.full(tk, y)
        grid.record(tk, q, v, y[2 * nU:])
