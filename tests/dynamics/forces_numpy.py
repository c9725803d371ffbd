"""Numpy oracle of the built-in force elements' compiled kernels (pipeline.dynamics.forces:
the package writes each element's physics once, compiled; this is the same physics written
again in numpy, from each element's own fields and the numpy marker points).

:func:`force`, :func:`potential`, :func:`loads` and :func:`rates` evaluate one built-in
element; :class:`NumpyElement` wraps one as an element without a compiled form (the
compiled step then calls these numpy forms back). The hydraulic cylinder's scalar laws
(piston force, flows) are its module's compiled functions, called from here with numpy
geometry: their closed-form references are in tests/solver/test_hydraulic_cylinder.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.forces import (
    FollowerForce,
    ForceElement,
    HydraulicCylinder,
    JointForce,
    JointSpringDamper,
    LineForce,
    PointForce,
    SpringDamper,
    TableSpringDamper,
    Torque,
)
from pipeline.dynamics.forces.base import Load, marker_point
from pipeline.dynamics.forces.hydraulics import (
    _MEAS,
    _ON_MARKER,
    command_rates,
    marker_measurement,
    piston_force,
)
from pipeline.dynamics.forces.loads import history_value


def marker_twist(point) -> np.ndarray:
    """(n, 3) angular velocity of the marker frame per unit qd_i, ground axes, rad, from
    [w_i]x = dR/dq_i R^T (antisymmetric part)."""
    Om = point.dP[:, :3, :3] @ point.P[:3, :3].T
    return 0.5 * np.stack([Om[:, 2, 1] - Om[:, 1, 2], Om[:, 0, 2] - Om[:, 2, 0],
                           Om[:, 1, 0] - Om[:, 0, 1]], axis=1)


def line(system, el, tree, q):
    """(points a, b, length l (m), unit vector u (3,) a -> b, dl/dq (n,))."""
    a = marker_point(system, *el.marker_a, tree, q)
    b = marker_point(system, *el.marker_b, tree, q)
    d = b.R - a.R
    length = float(np.linalg.norm(d))
    if length < 1e-12:
        raise ConfigError(f"force element '{el.name}': the two markers coincide")
    u = d / length
    return a, b, length, u, (b.dR - a.dR) @ u


def _table_segment(el, x):
    xs, fs = np.asarray(el.deflection), np.asarray(el.force)
    k = int(np.clip(np.searchsorted(xs, x) - 1, 0, xs.size - 2))
    return k, xs, fs, (fs[k + 1] - fs[k]) / (xs[k + 1] - xs[k])


def _table_integral(el, x):
    k, xs, fs, slope = _table_segment(el, x)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (fs[1:] + fs[:-1]) * np.diff(xs))])
    dx = x - xs[k]
    return float(cum[k] + fs[k] * dx + 0.5 * slope * dx * dx)


def _spring_tension(el, length, rate):
    """(elastic tension + damper, the damper's part), N; positive pulls together."""
    x = length - el.free_length
    if type(el) is TableSpringDamper:
        k, xs, fs, slope = _table_segment(el, x)
        elastic = float(fs[k] + slope * (x - xs[k]))
    else:
        elastic = el.preload + el.stiffness * x
    return elastic + el.damping * rate, el.damping * rate


def _hydraulic_par(el, system):
    par = el.parameters()
    par[_MEAS] = el.measured_index(system.mechanism)
    return par


def push(el, system, tree, q, qd, t, z=None):
    """(push along the line (N, > 0 drives the markers apart), its non-conservative part)
    of a line element."""
    _, _, length, _, dl = line(system, el, tree, q)
    rate = float(dl @ qd)
    if isinstance(el, SpringDamper):
        T, damper = _spring_tension(el, length, rate)
        return -T, -damper
    if type(el) is LineForce:
        f = history_value(el.history, t, el.name) * float(el.force)
        return f, 0.0 if el.conservative else f
    if type(el) is HydraulicCylinder:
        z = el.own_states(z)
        f = piston_force(el.parameters(), float(z[0]), float(z[1]),
                         length - el.length_retracted, rate)
        return f, f
    raise TypeError(type(el))


def _point_vector(el, p, t):
    F = history_value(el.history, t, el.name) * np.asarray(el.force, float)
    return p.P[:3, :3] @ F if type(el) is FollowerForce else F


def _torque_vector(el, p, t):
    T = history_value(el.history, t, el.name) * np.asarray(el.torque, float)
    return p.P[:3, :3] @ T if el.follower else T


def force(el, system, tree, q, qd, t, z=None):
    """(Q (n,), its non-conservative part (n,))."""
    q = np.asarray(q, float)
    qd = np.zeros_like(q) if qd is None else np.asarray(qd, float)
    if type(el) in (SpringDamper, TableSpringDamper, LineForce, HydraulicCylinder):
        f, fnc = push(el, system, tree, q, qd, t, z)
        dl = line(system, el, tree, q)[4]
        return f * dl, fnc * dl
    Q = np.zeros_like(q)
    if type(el) is JointSpringDamper:
        i = system.mechanism.index(el.coordinate)
        Q[i] = -el.stiffness * (q[i] - el.free_value) - el.damping * qd[i]
        Qnc = np.zeros_like(q)
        Qnc[i] = -el.damping * qd[i]
        return Q, Qnc
    if isinstance(el, JointForce):
        Q[system.mechanism.index(el.coordinate)] = (
            history_value(el.history, t, el.name) * float(el.force))
    elif type(el) in (PointForce, FollowerForce):
        p = marker_point(system, *el.marker, tree, q, np.asarray(el.offset, float))
        Q = p.dR @ _point_vector(el, p, t)
    elif type(el) is Torque:
        p = marker_point(system, *el.marker, tree, q)
        Q = marker_twist(p) @ _torque_vector(el, p, t)
    else:
        raise TypeError(type(el))
    return Q, (np.zeros_like(Q) if el.conservative else Q)


def potential(el, system, tree, q) -> float:
    """V (J) of the conservative part."""
    q = np.asarray(q, float)
    if isinstance(el, SpringDamper):
        length = line(system, el, tree, q)[2]
        x = length - el.free_length
        if type(el) is TableSpringDamper:
            return _table_integral(el, x) - _table_integral(el, 0.0)
        return el.preload * x + 0.5 * el.stiffness * x * x
    if type(el) is JointSpringDamper:
        x = q[system.mechanism.index(el.coordinate)] - el.free_value
        return 0.5 * el.stiffness * x * x
    if not el.conservative or type(el) in (FollowerForce, Torque, HydraulicCylinder):
        return 0.0
    if isinstance(el, JointForce):
        return -float(el.force) * float(q[system.mechanism.index(el.coordinate)])
    if type(el) is PointForce:
        p = marker_point(system, *el.marker, tree, q, np.asarray(el.offset, float))
        return -float(np.asarray(el.force, float) @ p.R)
    if type(el) is LineForce:
        return -float(el.force) * line(system, el, tree, q)[2]
    raise TypeError(type(el))


def loads(el, system, tree, q, qd, t, z=None) -> tuple[Load, ...]:
    """The physical loads (ground axes)."""
    q = np.asarray(q, float)
    qd = np.zeros_like(q) if qd is None else np.asarray(qd, float)
    if type(el) in (SpringDamper, TableSpringDamper, LineForce, HydraulicCylinder):
        f = push(el, system, tree, q, qd, t, z)[0]
        a, b, _, u, _ = line(system, el, tree, q)
        return (Load(el.marker_a[0], a.R, -f * u, np.zeros(3)),
                Load(el.marker_b[0], b.R, f * u, np.zeros(3)))
    if type(el) in (PointForce, FollowerForce):
        p = marker_point(system, *el.marker, tree, q, np.asarray(el.offset, float))
        return (Load(el.marker[0], p.R, _point_vector(el, p, t), np.zeros(3)),)
    if type(el) is Torque:
        p = marker_point(system, *el.marker, tree, q)
        return (Load(el.marker[0], p.R, np.zeros(3), _torque_vector(el, p, t)),)
    return ()  # on a coordinate: transmitted through its joint


def rates(el, system, tree, q, qd, t, z) -> np.ndarray:
    """The hydraulic cylinder's state rates (p_a', p_b'[, p_s'][, spool][, x_i'])."""
    z = el.own_states(z)
    q, qd = np.asarray(q, float), np.asarray(qd, float)
    _, _, length, _, dl = line(system, el, tree, q)
    par = _hydraulic_par(el, system)
    ym = ymd = 0.0
    if par[_MEAS] == _ON_MARKER:
        link, frame, axis = marker_measurement(el.command.measured)
        mp = marker_point(system, link, frame, tree, q)
        ym, ymd = float(mp.R[axis]), float(mp.dR[:, axis] @ qd)
    out = np.empty(z.size)
    rate = el.command.rate(t) if el.controlled else 0.0
    command_rates(par, history_value(el.command, t, el.name), rate, length, float(dl @ qd),
                  ym, ymd, q, qd, z, 0, out)
    return out


@dataclass(frozen=True)
class NumpyElement(ForceElement):
    """A built-in element evaluated by this oracle, as an element without a compiled form
    (its own name, states and conservativeness)."""

    name: str
    inner: Any

    @classmethod
    def of(cls, el) -> NumpyElement:
        out = cls(el.name, el)
        for attr in ("STATES", "STATE_UNITS"):
            object.__setattr__(out, attr, tuple(getattr(el, attr)))
        return out

    @property
    def conservative(self) -> bool:
        return self.inner.conservative

    def initial_states(self):
        return self.inner.initial_states()

    def state_scales(self):
        return self.inner.state_scales()

    def _force(self, system, tree, q, qd, t, z=None):
        return force(self.inner, system, tree, q, qd, t, z)[0]

    def nonconservative_force(self, system, tree, q, qd, t, z=None):
        return force(self.inner, system, tree, q, qd, t, z)[1]

    def potential_energy(self, system, tree, q):
        return potential(self.inner, system, tree, q)

    def loads(self, system, tree, q, qd, t, z=None):
        return loads(self.inner, system, tree, q, qd, t, z)

    def state_rates(self, system, tree, q, qd, t, z):
        return rates(self.inner, system, tree, q, qd, t, z)


__all__ = ["NumpyElement", "force", "line", "loads", "marker_twist", "potential", "push",
           "rates"]
