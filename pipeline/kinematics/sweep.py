"""Kinematic sweep: drivers over time -> positions, velocities, accelerations.

Any object with ``value(t)``, ``rate(t)`` and ``accel(t)`` (floats; see
:mod:`pipeline.kinematics.drivers`) drives the coordinate it is keyed by.
Modal coordinates without a driver stay at their ``q_guess`` value; free
coordinates (DOF left after the drivers, e.g. a passive spin or a free
chassis) are held at their value. An under-driven mechanism has no unique
motion: after a re-selection a different coordinate is the held one, so the
rates of such a mechanism may jump there (``reselections`` lists the times).

At every time the dependent coordinates are predicted by a second-order
Taylor step, closed by Newton (:func:`solve_position`), then the velocity and
acceleration equations are solved. The dependent set is re-selected when the
reciprocal condition number of its (normalised) block falls by more than
``reselect_factor`` since the last selection; a block that cannot be made
regular is a singular configuration.

Failures come back as a status (``success=False`` with a message naming the
time, the driver values and the loop or the joints), with the results up to
the failure kept (the rest NaN).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics.links import rigid_link
>>> from pipeline.kinematics.joints import Joint
>>> from pipeline.kinematics.mechanism import build_mechanism
>>> from pipeline.kinematics.rotations import translation
>>> class Spin:  # any object with value/rate/accel
...     def value(self, t): return 2.0 * t
...     def rate(self, t): return 2.0
...     def accel(self, t): return 0.0
>>> m = build_mechanism([rigid_link("ground"), rigid_link("arm", {"tip": translation([1, 0, 0])})],
...                     [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> res = sweep(m, {"pin.theta": Spin()}, np.linspace(0, 1, 5), markers=[("arm", "tip")])
>>> res.success, np.round(res.marker_velocity["arm.tip"][0], 12).tolist()
(True, [0.0, 2.0, 0.0])
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pipeline.core.errors import ConfigError, KinematicsError
from pipeline.core.progress import progress_bar
from pipeline.kinematics.analysis import (
    assemble,
    solve_acceleration,
    solve_position,
    solve_velocity,
)
from pipeline.kinematics.closure import closure
from pipeline.kinematics.mechanism import Mechanism
from pipeline.kinematics.partition import normalised_jacobian, select_partition
from pipeline.kinematics.poses import step_value

__all__ = ["SweepResult", "sweep"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SweepResult:
    """Time histories of a kinematic sweep.

    Attributes
    ----------
    t : (N,) times, s.
    q, qd, qdd : (N, n) coordinates and their first/second time derivatives.
    coordinates : names of the n coordinates.
    markers : {"link.frame": (N, 4, 4) global poses}.
    marker_velocity, marker_acceleration : {"link.frame": (N, 3)} of the frame origin, m/s, m/s^2.
    success : False if the sweep stopped early; ``message`` says why.
    n_done : number of time points solved.
    newton_iterations : (N,) iterations per point.
    reselections : times at which the dependent coordinates were re-selected.
    free : names of free coordinates held fixed.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    coordinates: tuple[str, ...]
    markers: dict[str, np.ndarray]
    marker_velocity: dict[str, np.ndarray]
    marker_acceleration: dict[str, np.ndarray]
    success: bool
    message: str
    n_done: int
    newton_iterations: np.ndarray
    reselections: tuple[float, ...] = field(default=())
    free: tuple[str, ...] = field(default=())

    def __getitem__(self, name: str) -> np.ndarray:
        """(N,) history of coordinate ``name``."""
        if name not in self.coordinates:
            raise ConfigError(f"coordinate '{name}' does not exist; coordinates: "
                              f"{list(self.coordinates)}")
        return self.q[:, self.coordinates.index(name)]


def _check_times(t) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ConfigError("t: expected a non-empty 1-D array of finite, increasing times (s)")
    return t


def _driver_state(drivers, t):
    return (np.array([float(d.value(t)) for d in drivers]),
            np.array([float(d.rate(t)) for d in drivers]),
            np.array([float(d.accel(t)) for d in drivers]))


class _Markers:
    def __init__(self, mech: Mechanism, markers: Sequence[tuple[str, str]], N: int):
        self.steps = [(f"{l}.{f}", mech.marker(l, f)) for l, f in markers]
        self.P = {k: np.full((N, 4, 4), np.nan) for k, _ in self.steps}
        self.V = {k: np.full((N, 3), np.nan) for k, _ in self.steps}
        self.Acc = {k: np.full((N, 3), np.nan) for k, _ in self.steps}

    def record(self, k, q, qd, qdd, tree_j, tree_g):
        """Store marker poses at point k from the trees with dA (tree_j) and with rates (tree_g)."""
        for name, st in self.steps:
            vj = step_value(st, tree_j.A, tree_j.dA, None, None, q, None, True)
            vg = step_value(st, tree_g.A, None, tree_g.Ad, tree_g.Add, q, qd, False)
            self.P[name][k] = vg.P
            self.V[name][k] = vg.Pd[:3, 3]
            self.Acc[name][k] = vg.Pdd[:3, 3] + np.einsum("n,nj->j", qdd, vj.dP[:, :3, 3])


def sweep(mech: Mechanism, drivers: Mapping[str, object], t, q_guess: np.ndarray | None = None,
          markers: Sequence[tuple[str, str]] = (), *, tol: float = 1e-12,
          reselect_factor: float = 10.0) -> SweepResult:
    """Kinematic analysis along the drivers at times ``t``.

    Parameters
    ----------
    drivers : {coordinate name: driver with value/rate/accel(t)}.
    t : (N,) increasing times, s.
    q_guess : (n,) approximate assembly at t[0] (default ``mech.q_initial``).
    markers : (link, frame) pairs whose global pose, origin velocity and
        acceleration are recorded.
    tol : closure tolerance (see :func:`solve_position`).
    reselect_factor : re-select the dependent coordinates when the block's
        rcond drops below 1/reselect_factor of its value at selection.
    """
    t = _check_times(t)
    names = list(drivers)
    idx = mech.indices(names)
    drv = [drivers[k] for k in names]
    N, n = t.size, mech.n
    Q, Qd, Qdd = (np.full((N, n), np.nan) for _ in range(3))
    its = np.zeros(N, dtype=int)
    rec = _Markers(mech, markers, N)
    q = np.array(mech.q_initial if q_guess is None else q_guess, dtype=float)
    v, _, _ = _driver_state(drv, t[0])
    q[idx] = v
    reselections, message, done = [], "ok", 0
    try:
        part = assemble(mech, q, names, tol=tol).partition
        rank = len(part.rows)
        qd, qdd = np.zeros(n), np.zeros(n)
        for k in progress_bar(range(N), total=N, description="kinematic sweep"):
            tk = t[k]
            v, vd, vdd = _driver_state(drv, tk)
            if k:  # Taylor predictor for the dependent coordinates
                dt = tk - t[k - 1]
                q[part.dependent] += qd[part.dependent] * dt + 0.5 * qdd[part.dependent] * dt**2
            q[idx], qd[:], qdd[:] = v, 0.0, 0.0
            qd[idx], qdd[idx] = vd, vdd
            ctx = dict(zip(names, v))
            q, c, its[k] = _solve_point(mech, q, part, tol, tk, ctx)
            new = _reselect(mech, c.J, part, rank, reselect_factor, tk, ctx, q)
            if new is not None:
                part = new
                reselections.append(float(tk))
            qd = solve_velocity(c.J, part, qd)
            cg = closure(mech, q, qd, jacobian=False)
            qdd = solve_acceleration(c.J, cg.gamma, part, qdd)
            Q[k], Qd[k], Qdd[k] = q, qd, qdd
            rec.record(k, q, qd, qdd, c.tree, cg.tree)
            done = k + 1
    except KinematicsError as exc:
        tk = t[done] if done < N else t[-1]
        message = f"sweep stopped at t = {tk:.6g} s (point {done} of {N}): {exc}"
        logger.warning(message)
    free = () if done == 0 else tuple(mech.coordinates[i] for i in part.free)
    return SweepResult(t, Q, Qd, Qdd, mech.coordinates, rec.P, rec.V, rec.Acc, done == N,
                       message, done, its, tuple(reselections), free)


def _reselect(mech, J, part, rank, factor, tk, ctx, q):
    """A new partition if the dependent block's rcond fell by more than ``factor``, else None."""
    Jn = normalised_jacobian(mech, J)[0][part.rows][:, part.dependent]
    s = np.linalg.svd(Jn, compute_uv=False) if Jn.size else np.ones(1)
    if not (s.size and s[-1] / s[0] < part.rcond / factor):
        return None
    new = select_partition(mech, J, part.prescribed, t=tk, drivers=ctx, q=q, expected_rank=rank,
                           secondary=part.secondary)
    logger.info("re-selected dependent coordinates at t = %.6g s: %s", tk,
                [mech.coordinates[i] for i in new.dependent])
    return new


def _solve_point(mech, q, part, tol, tk, ctx):
    try:
        return solve_position(mech, q, part, tol=tol)
    except KinematicsError as exc:
        drv = ", ".join(f"{k} = {v:.6g}" for k, v in ctx.items())
        raise type(exc)(f"with {drv}: {exc}", *_exc_args(exc)) from exc


def _exc_args(exc):
    if hasattr(exc, "q_closest"):
        return exc.loop, exc.cut_joint, exc.residual, exc.q_closest
    return ()
