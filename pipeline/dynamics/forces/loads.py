"""Applied loads: forces (fixed direction, follower, along a line), torques, joint loads.

Magnitudes are a constant or a time history (any object with ``value(t)``,
e.g. a :mod:`pipeline.kinematics.drivers` driver, or a plain callable t -> float).
An element with a constant magnitude and a ground-fixed direction is conservative
(V = -F . R, or -f l along a line, or -f q on a coordinate).

Examples
--------
>>> PointForce("w", ("bucket", "LOAD"), (0.0, 0.0, -4448.2)).conservative
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.core.errors import ConfigError
from pipeline.core.validate import validate_array
from pipeline.dynamics.forces.base import (
    ForceElement,
    LineElement,
    Load,
    check_coordinate,
    check_marker,
    marker_point,
    marker_twist,
    point_load,
)
from pipeline.dynamics.forces.markers import (
    frame_twist,
    line_geometry,
    marker_frame,
)
from pipeline.dynamics.forces.markers import (
    marker_point as point_kernel,
)

__all__ = [
    "FollowerForce",
    "ForceCylinder",
    "JointForce",
    "LineForce",
    "PointForce",
    "Torque",
    "history_value",
]


def history_value(history: Any, t: float, name: str) -> float:
    """Scale factor of a time history at t: number, ``value(t)`` object or callable."""
    if history is None:
        return 1.0
    if isinstance(history, int | float):
        return float(history)
    f = history.value if hasattr(history, "value") else history
    if not callable(f):
        raise ConfigError(f"force element '{name}': history: expected a number, a driver "
                          f"with value(t) or a callable, got {type(history).__name__}")
    return float(f(t))


def history_rate(history: Any, t: float) -> float:
    """The rate of a time history at t (1/s of its value): its ``rate(t)`` where it has one
    (a driver, a table), else 0 (a number, a held value)."""
    f = getattr(history, "rate", None)
    return float(f(t)) if callable(f) else 0.0


@dataclass(frozen=True)
class PointForce(ForceElement):
    """Force (3,) N in ground axes at a point ``offset`` (3,) m of a marker frame,
    scaled by ``history`` (None: constant)."""

    name: str
    marker: tuple[str, str]
    force: tuple
    offset: tuple = (0.0, 0.0, 0.0)
    history: Any = None
    #: kind of the compiled form (:mod:`pipeline.dynamics.forces.compiled`)
    KIND: ClassVar[int] = 3

    def __post_init__(self):
        validate_array(self.force, (3,), f"force element '{self.name}': force")
        validate_array(self.offset, (3,), f"force element '{self.name}': offset")

    def pack(self, mech, markers) -> tuple:
        """(ints (4,), par (6,), table rows or None) of the compiled form."""
        return ([markers.add(self.marker, self.offset), 0, 0, 0],
                [0.0, 0.0, 0.0, *np.asarray(self.force, dtype=float)], None)

    @property
    def conservative(self) -> bool:
        return self.history is None

    def validate(self, system) -> None:
        check_marker(system, self.marker, self.name, "marker")

    def _point(self, system, tree, q):
        return marker_point(system, *self.marker, tree, q, np.asarray(self.offset, float))

    def _vector(self, p, t):
        return history_value(self.history, t, self.name) * np.asarray(self.force, float)

    def _force(self, system, tree, q, qd, t):
        p = self._point(system, tree, q)
        return p.dR @ self._vector(p, t)

    def loads(self, system, tree, q, qd, t):
        p = self._point(system, tree, q)
        return (point_load(self.marker[0], p.R, self._vector(p, t)),)

    def potential_energy(self, system, tree, q) -> float:
        if not self.conservative:
            return 0.0
        return -float(np.asarray(self.force, float) @ self._point(system, tree, q).R)


@dataclass(frozen=True)
class FollowerForce(PointForce):
    """Force (3,) N given in the marker frame's axes (turns with the marker)."""

    KIND: ClassVar[int] = 5

    @property
    def conservative(self) -> bool:
        return False

    def _vector(self, p, t):
        return history_value(self.history, t, self.name) * (p.P[:3, :3] @ np.asarray(self.force))

    def potential_energy(self, system, tree, q) -> float:
        return 0.0


@dataclass(frozen=True)
class LineForce(LineElement):
    """Force of magnitude ``force`` (N, positive pushes the markers apart) along the
    line from marker_a to marker_b, equal and opposite on the two markers."""

    name: str
    marker_a: tuple[str, str]
    marker_b: tuple[str, str]
    force: float
    history: Any = None
    KIND: ClassVar[int] = 6

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([markers.add(self.marker_a), markers.add(self.marker_b), 0, 0],
                [0.0, 0.0, 0.0, float(self.force), 0.0, 0.0], None)

    @property
    def conservative(self) -> bool:
        return self.history is None

    def _force(self, system, tree, q, qd, t):
        f = history_value(self.history, t, self.name) * float(self.force)
        return f * self.line(system, tree, q)[4]

    def loads(self, system, tree, q, qd, t):
        f = history_value(self.history, t, self.name) * float(self.force)
        return self.line_loads(system, tree, q, f)

    def potential_energy(self, system, tree, q) -> float:
        if not self.conservative:
            return 0.0
        return -float(self.force) * self.line(system, tree, q)[2]


@dataclass(frozen=True)
class Torque(ForceElement):
    """Torque (3,) N m on a marker's link, in ground axes or (``follower``) in the
    marker frame's axes, scaled by ``history``."""

    name: str
    marker: tuple[str, str]
    torque: tuple
    follower: bool = False
    history: Any = None
    KIND: ClassVar[int] = 7

    def __post_init__(self):
        validate_array(self.torque, (3,), f"force element '{self.name}': torque")

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([markers.add(self.marker), int(bool(self.follower)), 0, 0],
                [0.0, 0.0, 0.0, *np.asarray(self.torque, dtype=float)], None)

    def validate(self, system) -> None:
        check_marker(system, self.marker, self.name, "marker")

    def _vector(self, p, t):
        T = history_value(self.history, t, self.name) * np.asarray(self.torque, float)
        return p.P[:3, :3] @ T if self.follower else T

    def _force(self, system, tree, q, qd, t):
        p = marker_point(system, *self.marker, tree, q)
        return marker_twist(p) @ self._vector(p, t)

    def loads(self, system, tree, q, qd, t):
        p = marker_point(system, *self.marker, tree, q)
        return (Load(self.marker[0], p.R, np.zeros(3), self._vector(p, t)),)


@dataclass(frozen=True)
class JointForce(ForceElement):
    """Generalized force (N or N m) on one coordinate, scaled by ``history``."""

    name: str
    coordinate: str
    force: float = 1.0
    history: Any = None
    KIND: ClassVar[int] = 1

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([mech.index(self.coordinate), 0, 0, 0],
                [0.0, 0.0, 0.0, float(self.force), 0.0, 0.0], None)

    @property
    def conservative(self) -> bool:
        return self.history is None

    def validate(self, system) -> None:
        check_coordinate(system, self.coordinate, self.name)

    def loads(self, system, tree, q, qd, t):
        return ()  # transmitted through the joint of ``coordinate``

    def _force(self, system, tree, q, qd, t):
        Q = np.zeros_like(q)
        Q[system.mechanism.index(self.coordinate)] = (
            history_value(self.history, t, self.name) * float(self.force))
        return Q

    def potential_energy(self, system, tree, q) -> float:
        if not self.conservative:
            return 0.0
        return -float(self.force) * float(q[system.mechanism.index(self.coordinate)])


@dataclass(frozen=True)
class ForceCylinder(JointForce):
    """Force-driven cylinder: force (N, positive extends) along a prismatic joint's
    coordinate with the time history ``history``."""

    def validate(self, system) -> None:
        i = check_coordinate(system, self.coordinate, self.name)
        mech = system.mechanism
        owner = mech.joint_of(i)
        kind = next((j.kind.name for j in mech.joints if j.name == owner), None)
        if kind not in ("prismatic", "cylindrical") or not self.coordinate.endswith(".d"):
            raise ConfigError(f"force element '{self.name}': coordinate: expected the stroke "
                              f"of a prismatic joint, got '{self.coordinate}'")


# --------------------------------------------------------------------------- compiled forms
# Each kernel adds element e's generalized force to Q and its non-conservative part to Qnc,
# or returns its potential energy, from the flat ForceData d (pipeline.dynamics.forces.
# markers) and the history factor (F,) of each element at the time; the numpy methods
# above are their reference (tests/solver/test_compiled_step).

@njit(cache=True)
def coordinate_force(e, q, v, A, dA, factor, d, Q, Qnc):
    i = d.ints[e, 0]
    f = d.par[e, 3] * factor[e]
    Q[i] += f
    if not d.conservative[e]:
        Qnc[i] += f


@njit(cache=True)
def coordinate_potential(e, q, A, dA, d):
    return -d.par[e, 3] * q[d.ints[e, 0]] if d.conservative[e] else 0.0


@njit(cache=True)
def _add_along(dp, F, Q, Qnc, conservative):
    for i in range(Q.shape[0]):
        s = dp[i, 0] * F[0] + dp[i, 1] * F[1] + dp[i, 2] * F[2]
        Q[i] += s
        if not conservative:
            Qnc[i] += s


@njit(cache=True)
def point_force(e, q, v, A, dA, factor, d, Q, Qnc):
    p, dp = np.zeros(3), np.zeros((q.shape[0], 3))
    point_kernel(d.ints[e, 0], q, A, dA, d, p, dp)
    _add_along(dp, factor[e] * d.par[e, 3:6], Q, Qnc, d.conservative[e])


@njit(cache=True)
def point_potential(e, q, A, dA, d):
    if not d.conservative[e]:
        return 0.0
    p, dp = np.zeros(3), np.zeros((q.shape[0], 3))
    point_kernel(d.ints[e, 0], q, A, dA, d, p, dp)
    return -(d.par[e, 3] * p[0] + d.par[e, 4] * p[1] + d.par[e, 5] * p[2])


@njit(cache=True)
def follower_force(e, q, v, A, dA, factor, d, Q, Qnc):
    n = q.shape[0]
    p, dp = np.zeros(3), np.zeros((n, 3))
    R, dR = np.zeros((3, 3)), np.zeros((n, 3, 3))
    point_kernel(d.ints[e, 0], q, A, dA, d, p, dp)
    marker_frame(d.ints[e, 0], q, A, dA, d, R, dR)
    _add_along(dp, R @ (factor[e] * d.par[e, 3:6]), Q, Qnc, False)


@njit(cache=True)
def line_force(e, q, v, A, dA, factor, d, Q, Qnc):
    _, dl = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
    f = factor[e] * d.par[e, 3]
    for i in range(q.shape[0]):
        Q[i] += f * dl[i]
        if not d.conservative[e]:
            Qnc[i] += f * dl[i]


@njit(cache=True)
def line_potential(e, q, A, dA, d):
    if not d.conservative[e]:
        return 0.0
    length, _ = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
    return -d.par[e, 3] * length


@njit(cache=True)
def torque(e, q, v, A, dA, factor, d, Q, Qnc):
    n = q.shape[0]
    R, dR, w = np.zeros((3, 3)), np.zeros((n, 3, 3)), np.zeros((n, 3))
    marker_frame(d.ints[e, 0], q, A, dA, d, R, dR)
    frame_twist(R, dR, w)
    T = factor[e] * d.par[e, 3:6]
    if d.ints[e, 1]:  # given in the marker frame's axes
        T = R @ T
    _add_along(w, T, Q, Qnc, False)


@njit(cache=True)
def no_potential(e, q, A, dA, d):
    return 0.0
