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
    CompiledElement,
    CoordinateElement,
    Kernels,
    LineElement,
    check_coordinate,
    check_marker,
)
from pipeline.dynamics.forces.markers import (
    frame_twist,
    line_geometry,
    load_row,
    marker_frame,
    no_potential,
)
from pipeline.dynamics.forces.markers import (
    marker_point as point_kernel,
)
from pipeline.kinematics.driver_base import Driver

__all__ = [
    "FollowerForce",
    "ForceCylinder",
    "JointForce",
    "LineForce",
    "PointForce",
    "Torque",
    "history_rate",
    "history_rates",
    "history_value",
    "history_values",
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


def history_values(history: Any, times: np.ndarray, name: str = "history") -> np.ndarray:
    """:func:`history_value` at each of ``times`` (k,) s: at once for a driver (drivers take
    arrays of times) or an object with ``values_at(times)`` (a controller: its
    reference's), point by point otherwise (a user's callable)."""
    return _at_times(history, times, "value", "values_at",
                     lambda t: history_value(history, t, name))


def history_rates(history: Any, times: np.ndarray) -> np.ndarray:
    """:func:`history_rate` at each of ``times`` (k,) s, at once where
    :func:`history_values` is."""
    return _at_times(history, times, "rate", "rates_at", lambda t: history_rate(history, t))


def _at_times(history, times, method: str, many: str, one) -> np.ndarray:
    """(k,) a driver's ``method`` at the ``times``, or the history's own ``many``(times),
    else ``one``(t) at each."""
    times = np.asarray(times, dtype=float).reshape(-1)
    if isinstance(history, Driver):
        return np.broadcast_to(np.asarray(getattr(history, method)(times), dtype=float),
                               times.shape).copy()
    f = getattr(history, many, None)
    if callable(f):
        return np.asarray(f(times), dtype=float).reshape(times.shape)
    return np.array([one(float(t)) for t in times], dtype=float)


def history_rate(history: Any, t: float) -> float:
    """The rate of a time history at t (1/s of its value): its ``rate(t)`` where it has one
    (a driver, a table), else 0 (a number, a held value)."""
    f = getattr(history, "rate", None)
    return float(f(t)) if callable(f) else 0.0


@dataclass(frozen=True)
class PointForce(CompiledElement):
    """Force (3,) N in ground axes at a point ``offset`` (3,) m of a marker frame,
    scaled by ``history`` (None: constant)."""

    name: str
    marker: tuple[str, str]
    force: tuple
    offset: tuple = (0.0, 0.0, 0.0)
    history: Any = None
    #: kind of the compiled form (:mod:`pipeline.dynamics.forces.compiled`)
    KIND: ClassVar[int] = 3
    TYPE: ClassVar[str] = "point_force"

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


@dataclass(frozen=True)
class FollowerForce(PointForce):
    """Force (3,) N given in the marker frame's axes (turns with the marker)."""

    KIND: ClassVar[int] = 5
    TYPE: ClassVar[str] = "follower_force"

    @property
    def conservative(self) -> bool:
        return False


@dataclass(frozen=True)
class LineForce(CompiledElement, LineElement):
    """Force of magnitude ``force`` (N, positive pushes the markers apart) along the
    line from marker_a to marker_b, equal and opposite on the two markers."""

    name: str
    marker_a: tuple[str, str]
    marker_b: tuple[str, str]
    force: float
    history: Any = None
    KIND: ClassVar[int] = 6
    TYPE: ClassVar[str] = "line_force"

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([markers.add(self.marker_a), markers.add(self.marker_b), 0, 0],
                [0.0, 0.0, 0.0, float(self.force), 0.0, 0.0], None)

    @property
    def conservative(self) -> bool:
        return self.history is None


@dataclass(frozen=True)
class Torque(CompiledElement):
    """Torque (3,) N m on a marker's link, in ground axes or (``follower``) in the
    marker frame's axes, scaled by ``history``."""

    name: str
    marker: tuple[str, str]
    torque: tuple
    follower: bool = False
    history: Any = None
    KIND: ClassVar[int] = 7
    TYPE: ClassVar[str] = "torque"

    def __post_init__(self):
        validate_array(self.torque, (3,), f"force element '{self.name}': torque")

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([markers.add(self.marker), int(bool(self.follower)), 0, 0],
                [0.0, 0.0, 0.0, *np.asarray(self.torque, dtype=float)], None)

    def validate(self, system) -> None:
        check_marker(system, self.marker, self.name, "marker")


@dataclass(frozen=True)
class JointForce(CompiledElement, CoordinateElement):
    """Generalized force (N or N m) on one coordinate, scaled by ``history`` (transmitted
    through the joint of ``coordinate``: no loads of its own)."""

    name: str
    coordinate: str
    force: float = 1.0
    history: Any = None
    KIND: ClassVar[int] = 1
    TYPE: ClassVar[str] = "joint_force"

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([mech.index(self.coordinate), 0, 0, 0],
                [0.0, 0.0, 0.0, float(self.force), 0.0, 0.0], None)

    @property
    def conservative(self) -> bool:
        return self.history is None


@dataclass(frozen=True)
class ForceCylinder(JointForce):
    """Force-driven cylinder: force (N, positive extends) along a prismatic joint's
    coordinate with the time history ``history``."""

    TYPE: ClassVar[str] = "force_cylinder"

    def validate(self, system) -> None:
        i = check_coordinate(system, self.coordinate, self.name)
        mech = system.mechanism
        owner = mech.joint_of(i)
        kind = next((j.kind.name for j in mech.joints if j.name == owner), None)
        if kind not in ("prismatic", "cylindrical") or not self.coordinate.endswith(".d"):
            raise ConfigError(f"force element '{self.name}': coordinate: expected the stroke "
                              f"of a prismatic joint, got '{self.coordinate}'")


# --------------------------------------------------------------------------- compiled forms
# The physics of these elements, once: element e's generalized force added to Q and its
# non-conservative part to Qnc, a line force's push, its potential energy, or its physical
# loads (rows of link, point, force, torque: pipeline.dynamics.forces.markers.load_row),
# from the flat ForceData d (pipeline.dynamics.forces.markers) and the history factor (F,)
# of each element at the time. The numpy oracle is tests/dynamics/forces_numpy.py.

@njit(cache=True)
def coordinate_force(e, q, v, z, A, dA, factor, d, Q, Qnc):
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
def point_force(e, q, v, z, A, dA, factor, d, Q, Qnc):
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
def point_loads(e, q, v, z, A, dA, factor, d, rows):
    """One row: the force (ground axes) at its point. Returns 1."""
    p, dp = np.zeros(3), np.zeros((q.shape[0], 3))
    point_kernel(d.ints[e, 0], q, A, dA, d, p, dp)
    load_row(rows[0], d.link[d.ints[e, 0]], p, factor[e] * d.par[e, 3:6], np.zeros(3))
    return 1


@njit(cache=True)
def _follower_vector(e, q, A, dA, factor, d, dp):
    """(the point (3,), the force in ground axes (3,)); dp (n, 3) filled with dp/dq."""
    n = q.shape[0]
    p = np.zeros(3)
    R, dR = np.zeros((3, 3)), np.zeros((n, 3, 3))
    point_kernel(d.ints[e, 0], q, A, dA, d, p, dp)
    marker_frame(d.ints[e, 0], q, A, dA, d, R, dR)
    return p, R @ (factor[e] * d.par[e, 3:6])


@njit(cache=True)
def follower_force(e, q, v, z, A, dA, factor, d, Q, Qnc):
    dp = np.zeros((q.shape[0], 3))
    _, F = _follower_vector(e, q, A, dA, factor, d, dp)
    _add_along(dp, F, Q, Qnc, False)


@njit(cache=True)
def follower_loads(e, q, v, z, A, dA, factor, d, rows):
    p, F = _follower_vector(e, q, A, dA, factor, d, np.zeros((q.shape[0], 3)))
    load_row(rows[0], d.link[d.ints[e, 0]], p, F, np.zeros(3))
    return 1


@njit(cache=True)
def line_force_push(e, z, length, rate, factor, d):
    """(f, its non-conservative part): the force pushing the markers apart, N."""
    f = factor[e] * d.par[e, 3]
    return f, 0.0 if d.conservative[e] else f


@njit(cache=True)
def line_potential(e, q, A, dA, d):
    if not d.conservative[e]:
        return 0.0
    length, _ = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
    return -d.par[e, 3] * length


@njit(cache=True)
def _torque_vector(e, q, A, dA, factor, d, w):
    """The torque in ground axes (3,); w (n, 3) filled with the frame's twist."""
    n = q.shape[0]
    R, dR = np.zeros((3, 3)), np.zeros((n, 3, 3))
    marker_frame(d.ints[e, 0], q, A, dA, d, R, dR)
    frame_twist(R, dR, w)
    T = factor[e] * d.par[e, 3:6]
    return R @ T if d.ints[e, 1] else T  # ints[e, 1]: given in the marker frame's axes


@njit(cache=True)
def torque(e, q, v, z, A, dA, factor, d, Q, Qnc):
    w = np.zeros((q.shape[0], 3))
    _add_along(w, _torque_vector(e, q, A, dA, factor, d, w), Q, Qnc, False)


@njit(cache=True)
def torque_loads(e, q, v, z, A, dA, factor, d, rows):
    """One row: the torque on the marker's link (at the marker's origin)."""
    n = q.shape[0]
    T = _torque_vector(e, q, A, dA, factor, d, np.zeros((n, 3)))
    p, dp = np.zeros(3), np.zeros((n, 3))
    point_kernel(d.ints[e, 0], q, A, dA, d, p, dp)
    load_row(rows[0], d.link[d.ints[e, 0]], p, np.zeros(3), T)
    return 1


#: the compiled forms of this module's kinds (:class:`~.base.Kernels`)
KERNELS = (
    Kernels((JointForce, ForceCylinder), coordinate_potential, force=coordinate_force),
    Kernels((PointForce,), point_potential, force=point_force, loads=point_loads),
    Kernels((FollowerForce,), no_potential, force=follower_force, loads=follower_loads),
    Kernels((LineForce,), line_potential, push=line_force_push),
    Kernels((Torque,), no_potential, force=torque, loads=torque_loads),
)
