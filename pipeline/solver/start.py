"""The start of a run: (q0, qd0) made consistent with the loops and the drivers at t0.

Positions: the drivers' values at t0 are imposed; an unclosed q0 is moved onto the loops by
the least change of the other coordinates, and what moved is logged (a user who wants some
coordinates held assembles with :func:`pipeline.kinematics.initial_positions` first).
Velocities: every nonzero entry of qd0 is a rate the user gave and is honoured
(:func:`pipeline.kinematics.initial.initial_velocities`): the loops decide the others,
modal rates stay as given where they can, and a set of rates the loops cannot honour is a
ConfigError naming them. Nothing is dropped silently.
"""

from __future__ import annotations

import logging

import numpy as np

from pipeline.core.errors import KinematicsError
from pipeline.kinematics.analysis import assemble
from pipeline.kinematics.closure import closure
from pipeline.kinematics.initial import initial_velocities
from pipeline.solver.constrained import ConstrainedSystem

logger = logging.getLogger(__name__)

__all__ = ["consistent_start"]


def consistent_start(system, q0: np.ndarray, qd0: np.ndarray, t0: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(q0, qd0) consistent at t0 (see the module docstring)."""
    mech = system.mechanism
    cs = ConstrainedSystem(system)
    values, rates, _ = cs.drive(t0)
    q = np.array(q0, dtype=float)
    q[cs.P] = values
    if mech.topology.loops:
        w = np.asarray(mech.row_weights)
        if np.abs(w * closure(mech, q, jacobian=False).r).max() > 1e-12:
            q = _close(cs, mech, q, t0)
    driven = {mech.coordinates[i]: float(v) for i, v in zip(cs.P, rates)}
    given = {mech.coordinates[i]: float(v) for i, v in enumerate(qd0)
             if v != 0.0 and i not in set(cs.P)}
    qd = initial_velocities(mech, q, driven, given, qd_guess=np.asarray(qd0, dtype=float))
    return q, qd


def _close(cs: ConstrainedSystem, mech, q: np.ndarray, t0: float) -> np.ndarray:
    """q moved onto the loops by the least change (Gauss-Newton), or by the position analysis
    from there when the least-change iteration does not close them (a far start)."""
    q1 = cs.project_positions(t0, q, max_iter=20)
    w = np.asarray(mech.row_weights)
    if np.abs(w * closure(mech, q1, jacobian=False).r).max() > 1e-12:
        names = [mech.coordinates[i] for i in cs.P]
        try:
            q1 = assemble(mech, q1, names).q
        except KinematicsError as exc:
            raise type(exc)(f"initial state: the loops cannot be closed at t = {t0:g} s: "
                            f"{exc}") from None
    moved = [(mech.coordinates[i], q[i], q1[i]) for i in range(mech.n)
             if abs(q1[i] - q[i]) > 1e-9 * mech.coordinate_units[i]]
    if moved:
        logger.info("initial positions closed onto the loops: %s",
                    ", ".join(f"{n} {a:.9g} -> {b:.9g}" for n, a, b in moved))
    return q1
