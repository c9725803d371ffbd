"""Kinetostatics: the actuator forces a prescribed motion needs.

The driven coordinates s (``system.drivers``) and any ``hold`` coordinates
(default: every free joint coordinate left over, e.g. a chassis slide) are
prescribed; the loops close for the dependent ones. With B_c = dq/ds (n, c)
(:func:`pipeline.dynamics.statics.velocity_transform` on the prescribed
columns), the principle of virtual work in the prescribed coordinates gives
the generalized forces the drivers must apply (the Lagrange multipliers of the
driver constraints):

    quasi-static   lambda = -B_c^T Q_static(q, t)
    with inertia   lambda =  B_c^T (M q'' - rhs(q, q', t)),  rhs = Q - h,

with q', q'' from velocity and acceleration analysis (driver rates and
accelerations, held coordinates at rest). For a cylinder (driven prismatic
coordinate) lambda is its axial force in N, positive pushing (extending);
for a driven revolute it is the torque in N m. Flexible links: the modal
coordinates are solved for static equilibrium at each time (quasi-static
deflection; their rates are neglected in the inertial terms).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.kinematics.drivers import Ramp
>>> from pipeline.dynamics import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.eye(3))}, [0, -10.0, 0],
...            drivers={"pin.theta": Ramp(0.0, 1.0)})
>>> r = kinetostatics(s, np.array([0.0]), np.zeros(1))
>>> float(r.forces[0, 0])  # holding torque m g d
20.0
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.equations import equations
from pipeline.dynamics.statics import (
    reduced_coordinates,
    static_equilibrium,
    static_forces,
    velocity_transform,
)
from pipeline.kinematics import closure, solve_acceleration, solve_position, solve_velocity
from pipeline.kinematics.failures import ClosureError, SingularConfigurationError
from pipeline.kinematics.partition import select_partition

__all__ = ["KinetostaticResult", "kinetostatics"]


@dataclass(frozen=True)
class KinetostaticResult:
    """Actuator forces along a driver motion (partial on failure).

    Attributes
    ----------
    t : (T,) s.  q, qd, qdd : (T, n) coordinates, rates, accelerations.
    names : (c,) prescribed coordinates (drivers, then held ones).
    forces : (T, c) generalized force each must apply, N or N m.
    inertia : whether M q'' + h was included.
    success, message.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    names: tuple[str, ...]
    forces: np.ndarray
    inertia: bool
    success: bool
    message: str

    def force(self, name: str) -> np.ndarray:
        """(T,) force history of prescribed coordinate ``name``."""
        if name not in self.names:
            raise ConfigError(f"kinetostatics: '{name}' is not prescribed; prescribed: "
                              f"{list(self.names)}")
        return self.forces[:, self.names.index(name)]


def _held(system, q, hold):
    """Names of drivers + held coordinates (default: the free joint coordinates)."""
    if hold is None:
        _, red = reduced_coordinates(system, q)
        modal = set(system.mechanism.modal_coordinates.tolist())
        hold = [system.mechanism.coordinates[i] for i in red.x if i not in modal]
    return list(system.drivers) + [h for h in hold if h not in system.drivers]


def _state(system, q, red, t, names, idx):
    """Closed q, qd, qdd at t (drivers from their histories, held coordinates at rest)."""
    mech = system.mechanism
    qd, qdd = np.zeros(mech.n), np.zeros(mech.n)
    for name, drv in system.drivers.items():
        i = mech.index(name)
        q[i], qd[i], qdd[i] = drv.value(t), drv.rate(t), drv.accel(t)
    part = red.partition
    if part.dependent.size:
        q = solve_position(mech, q, part)[0]
        if red.x.size:  # modal coordinates: quasi-static deflection
            q = static_equilibrium(system, q, t=t, hold=names).q
        c = closure(mech, q, qd)
        qd = solve_velocity(c.J, part, qd)
        qdd = solve_acceleration(c.J, closure(mech, q, qd).gamma, part, qdd)
    elif red.x.size:
        q = static_equilibrium(system, q, t=t, hold=names).q
    return q, qd, qdd


def _repartition(system, q, red, idx):
    c = closure(system.mechanism, q)
    prescribed = np.concatenate([idx, system.mechanism.modal_coordinates]).astype(int)
    part = select_partition(system.mechanism, c.J, prescribed, q=q)
    return type(red)(red.x, red.held, part)


def kinetostatics(system, t: np.ndarray, q_guess: np.ndarray, *, inertia: bool = False,
                  hold=None) -> KinetostaticResult:
    """Actuator forces along the drivers' motion at times t (T,) s.

    Parameters
    ----------
    q_guess : (n,) approximate assembly at t[0].
    inertia : include M q'' + h (else quasi-static).
    hold : names of coordinates held fixed besides the drivers (default: every
        free joint coordinate); their holding forces are reported too.

    Raises
    ------
    ConfigError
        No drivers, bad times or q_guess.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if not system.drivers:
        raise ConfigError("kinetostatics: system.drivers: expected at least one driven "
                          "coordinate, got none")
    if t.ndim != 1 or not np.all(np.isfinite(t)):
        raise ConfigError(f"kinetostatics: t: expected finite times (T,), got {t.shape}")
    mech = system.mechanism
    q = np.array(q_guess, dtype=float)
    for name, drv in system.drivers.items():
        q[mech.index(name)] = drv.value(t[0])
    names = _held(system, q, hold)
    idx = mech.indices(names).astype(int)
    q, red = reduced_coordinates(system, q, names)
    Q = np.full((t.size, 3, mech.n), np.nan)
    F = np.full((t.size, idx.size), np.nan)
    ok, msg = True, "completed"
    for k, tk in enumerate(t):
        try:
            try:
                qk, qd, qdd = _state(system, q.copy(), red, tk, names, idx)
            except (ClosureError, SingularConfigurationError):
                red = _repartition(system, q, red, idx)
                qk, qd, qdd = _state(system, q.copy(), red, tk, names, idx)
            Bc = velocity_transform(system, qk, red, idx)
            if inertia:
                M, rhs = equations(system, qk, qd, tk)
                F[k] = Bc.T @ (M @ qdd - rhs)
            else:
                F[k] = -Bc.T @ static_forces(system, qk, tk)
        except (ClosureError, SingularConfigurationError, np.linalg.LinAlgError) as exc:
            ok, msg = False, f"stopped at t = {tk:.6g} s: {exc}"
            break
        q = qk
        Q[k] = qk, qd, qdd
    n_ok = k + 1 if ok else k
    return KinetostaticResult(t[:n_ok], Q[:n_ok, 0], Q[:n_ok, 1], Q[:n_ok, 2], tuple(names),
                              F[:n_ok], inertia, ok, msg)
