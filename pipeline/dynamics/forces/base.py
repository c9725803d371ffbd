"""Force-element contract and the marker helpers every element uses.

Contract of a :class:`ForceElement` subclass (thesis eqs. 4.148-4.174, DESIGN §4):

1. It is a frozen dataclass: a description, no state. Markers are given as
   ``(link, frame)`` pairs; coordinates by name (``"crank.theta"``).
2. ``generalized_force(system, tree, q, qd, t) -> (n,)`` is the virtual work
   of the element, Q_i = sum_k F_k . dR_k/dq_i + sum_k T_k . w_k,i, with
   R_k the global point where force F_k acts and w_k,i the angular velocity
   of the frame where torque T_k acts per unit qd_i. ``tree`` is the
   :class:`~pipeline.kinematics.TreeState` at q with ``dA`` (derivatives=True).
3. ``potential_energy(system, tree, q) -> float`` is V with Q = -dV/dq for
   the conservative part of the element (springs, constant forces), and 0
   for a non-conservative element (``conservative`` is False). Dampers and
   time histories are never in V.
4. ``power(system, tree, q, qd, t) -> float`` is the power the element
   delivers to the system, Q . qd. For a conservative element it equals
   -dV/dt; the energy balance of a run is
   T + V_gravity + V_elastic + sum V_elements = E_0 + int (non-conservative power) dt.
   ``nonconservative_force(...)`` is the part of Q that is not -dV/dq (the
   damper of a spring-damper, a time history, a follower load); its power is
   the non-conservative power. ``conservative`` is True when that part is zero.
5. ``loads(system, tree, q, qd, t)`` lists the physical loads as
   :class:`Load` (link, global point, force, torque) for joint reactions;
   elements acting on a joint coordinate set ``coordinate`` instead and
   return no loads (their force is transmitted through the joint).
6. Bad descriptions raise ConfigError naming the element and the field in
   ``validate(system)`` (called by the analyses before they start).
7. States. An element may carry first-order states of its own (a hydraulic chamber's
   pressure), named by ``STATES`` (the run reports them as ``<element>.<state>``), with
   ``initial_states()``, ``state_scales()`` (the size of a meaningful change: Newton's and
   the error estimate's units) and ``state_rates(system, tree, q, qd, t, z)``; its force
   methods then take its states ``z`` as a last argument. Only the transient
   generalised-alpha run integrates states (in the same step as the motion); an analysis
   that does not carry them (statics, linearisation, ...) gets a ConfigError naming the
   element from ``own_states``.
8. ``HISTORY`` names the field holding the element's time history (``history`` by
   default; a hydraulic cylinder's valve ``command``): the compiled step evaluates it
   once per step, and a stepping API's input by the element's name replaces it
   (``with_input``; a controlled cylinder's input is its controller's reference).

A user's own element subclasses :class:`ForceElement` and implements ``_force(system, tree,
q, qd, t)`` (and ``loads``); the public methods check the shapes once. The helpers
:func:`marker_pose` and :func:`marker_point` give a marker's pose and a point on it with
dR/dq and velocity. The built-in elements are :class:`CompiledElement`: their physics is
their compiled kernels, once.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.kinematics.poses import step_pose, step_value

__all__ = ["CompiledElement", "CoordinateElement", "ForceElement", "Kernels", "LineElement",
           "Load", "MarkerPoint",
           "check_coordinate", "check_marker", "element_forces", "marker_point", "marker_pose",
           "nonnegative"]


@dataclass(frozen=True)
class MarkerPoint:
    """A point fixed on a marker frame at one configuration.

    Attributes
    ----------
    R : (3,) global position, m.
    dR : (n, 3) dR/dq_i (m per unit coordinate).
    P : (4, 4) global pose of the marker frame.
    dP : (n, 4, 4) dP/dq_i.
    """

    R: np.ndarray
    dR: np.ndarray
    P: np.ndarray
    dP: np.ndarray

    def velocity(self, qd: np.ndarray) -> np.ndarray:
        """(3,) velocity of the point, m/s, for rates qd (n,)."""
        return qd @ self.dR


@dataclass(frozen=True)
class Load:
    """A physical load on ``link``: force (3,) N through point (3,) m plus torque (3,) N m,
    ground axes."""

    link: str
    point: np.ndarray
    force: np.ndarray
    torque: np.ndarray


def marker_pose(system, link: str, frame: str, tree, q: np.ndarray) -> np.ndarray:
    """(4, 4) global pose of marker ``frame`` on ``link`` (A_link S_frame(eta))."""
    step = system.mechanism.marker(link, frame)
    return step_pose(step, tree.A, q)


def marker_point(system, link: str, frame: str, tree, q: np.ndarray,
                 offset=None) -> MarkerPoint:
    """Point at ``offset`` (3,) m in the marker frame (default its origin) with dR/dq.

    Parameters
    ----------
    tree : TreeState at q with dA.
    q : (n,) coordinates.
    """
    step = system.mechanism.marker(link, frame)
    sv = step_value(step, tree.A, tree.dA, None, None, q, None, need_d=True)
    p = np.array([0.0, 0.0, 0.0, 1.0]) if offset is None else np.append(offset, 1.0)
    return MarkerPoint((sv.P @ p)[:3], (sv.dP @ p)[:, :3], sv.P, sv.dP)


def check_marker(system, marker, name: str, field: str) -> tuple[str, str]:
    """Validate a ``(link, frame)`` marker against the mechanism."""
    if not (isinstance(marker, tuple | list) and len(marker) == 2
            and all(isinstance(x, str) for x in marker)):
        raise ConfigError(f"force element '{name}': {field}: expected (link, frame), "
                          f"got {marker!r}")
    link = system.mechanism.links[system.mechanism.link_index(marker[0])]
    link.frame(marker[1])
    return tuple(marker)


def nonnegative(value, name: str, field: str) -> float:
    """``value`` as a finite float >= 0; ConfigError naming element ``name``'s ``field``
    otherwise."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if isinstance(value, bool) or not np.isfinite(v) or v < 0.0:
        raise ConfigError(f"force element '{name}': {field}: expected a finite value >= 0, "
                          f"got {value!r}")
    return v


def check_coordinate(system, coordinate: str, name: str) -> int:
    """Index of coordinate ``coordinate``; ConfigError naming the element otherwise."""
    try:
        return system.mechanism.index(coordinate)
    except ConfigError as exc:
        raise ConfigError(f"force element '{name}': coordinate: {exc}") from None


class ForceElement:
    """Base of every force element (see the module docstring for the contract)."""

    #: True when Q = -dV/dq holds for the element's ``potential_energy``.
    conservative: ClassVar[bool] = False
    #: names of the element's own states (contract rule 7) and their units; none by default
    STATES: ClassVar[tuple[str, ...]] = ()
    STATE_UNITS: ClassVar[tuple[str, ...]] = ()
    #: the field holding the element's time history (contract rule 8)
    HISTORY: ClassVar[str] = "history"
    name: str

    def initial_states(self) -> np.ndarray:
        """(k,) the states at the start of a run (k = len(STATES))."""
        return np.zeros(0)

    def state_scales(self) -> np.ndarray:
        """(k,) the size of a meaningful change of each state, in its unit."""
        return np.ones(len(self.STATES))

    def with_input(self, history) -> ForceElement:
        """This element with ``history`` (a ``value(t)`` object) in place of its own
        (contract rule 8)."""
        from dataclasses import replace

        return replace(self, **{self.HISTORY: history})

    def own_states(self, z) -> np.ndarray:
        """The element's states z (k,) as an array; ConfigError where the analysis asking
        has none to give (contract rule 7)."""
        if z is None:
            raise ConfigError(
                f"force element '{self.name}' ({type(self).__name__}) has states of its own "
                f"({', '.join(self.STATES)}): only a transient run by generalised-alpha "
                f"integrates them; this analysis cannot use it")
        z = np.asarray(z, dtype=float)
        if z.shape != (len(self.STATES),):
            raise ConfigError(f"force element '{self.name}': states: expected "
                              f"{len(self.STATES)} values, got shape {z.shape}")
        return z

    def validate(self, system) -> None:
        """Raise ConfigError if the element does not fit ``system``."""

    def generalized_force(self, system, tree, q, qd, t: float, z=None) -> np.ndarray:
        """(n,) Q by virtual work at (q, qd, t) (and the element's states z, rule 7);
        units N or N m per coordinate unit."""
        q = np.asarray(q, dtype=float)
        qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=float)
        args = (system, tree, q, qd, float(t)) + ((z,) if self.STATES else ())
        Q = np.asarray(self._force(*args), dtype=float)
        if Q.shape != q.shape:
            raise ConfigError(f"force element '{self.name}': generalized force has shape "
                              f"{Q.shape}, expected {q.shape}")
        return Q

    def potential_energy(self, system, tree, q) -> float:
        """V (J) of the conservative part; 0 for a non-conservative element."""
        return 0.0

    def nonconservative_force(self, system, tree, q, qd, t: float, z=None) -> np.ndarray:
        """(n,) part of Q that is not -dV/dq (all of Q for a non-conservative element)."""
        if self.conservative:
            return np.zeros(len(np.asarray(q)))
        return self.generalized_force(system, tree, q, qd, t, z)

    def power(self, system, tree, q, qd, t: float, z=None) -> float:
        """Power delivered to the system, W (Q . qd)."""
        return float(self.generalized_force(system, tree, q, qd, t, z) @ np.asarray(qd, float))

    def loads(self, system, tree, q, qd, t: float) -> tuple[Load, ...]:
        """Physical loads (ground axes) at (q, qd, t); see the contract, rule 5."""
        raise NotImplementedError(f"force element '{self.name}' does not list its loads")

    def _force(self, system, tree, q, qd, t):
        raise NotImplementedError(
            f"force element '{self.name}' ({type(self).__name__}) has no compiled form and "
            f"no _force method: a class of your own implements _force (and loads); "
            f"docs/force_elements.md")


def element_forces(system, f, tree, q, qd, t: float, z=None) -> tuple[np.ndarray, np.ndarray]:
    """(Q (n,), its non-conservative part (n,)) of force element ``f`` at (q, qd, t) and
    the system's element states z (nz,) or None (an analysis without them). A duck-typed
    element (no ``nonconservative_force``) is non-conservative unless it says otherwise."""
    args = (system, tree, q, qd, t, *system.states_of(f, z))
    Q = np.asarray(f.generalized_force(*args), dtype=float)
    if hasattr(f, "nonconservative_force"):
        Qnc = (np.zeros_like(Q) if f.conservative
               else np.asarray(f.nonconservative_force(*args), dtype=float))
    else:
        Qnc = np.zeros_like(Q) if getattr(f, "conservative", False) else Q
    return Q, Qnc


class CompiledElement(ForceElement):
    """Base of the built-in elements: their physics is written once, as the compiled
    kernels of their module (:mod:`pipeline.dynamics.forces.compiled`), and their methods
    evaluate those kernels (``system.compiled_forces``; the numpy form of each is the
    tests' oracle, ``tests/dynamics/forces_numpy.py``). A subclass a user makes of one is
    an element without a compiled form and implements ``_force`` itself (contract)."""

    def _terms(self, system, tree, q, qd, t, z):
        q = np.asarray(q, dtype=float)
        qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=float)
        return system.compiled_forces.element_forces(self, tree, q, qd, float(t), z)

    def generalized_force(self, system, tree, q, qd, t: float, z=None) -> np.ndarray:
        return self._terms(system, tree, q, qd, t, z)[0]

    def nonconservative_force(self, system, tree, q, qd, t: float, z=None) -> np.ndarray:
        return self._terms(system, tree, q, qd, t, z)[1]

    def potential_energy(self, system, tree, q) -> float:
        return system.compiled_forces.element_potential(self, tree, np.asarray(q, float))

    def loads(self, system, tree, q, qd, t: float, z=None) -> tuple[Load, ...]:
        q = np.asarray(q, dtype=float)
        qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=float)
        return system.compiled_forces.element_loads(self, tree, q, qd, float(t), z)

    def state_rates(self, system, tree, q, qd, t: float, z) -> np.ndarray:
        """(k,) the rates of the element's own states z (k,) at (q, qd, t)."""
        q = np.asarray(q, dtype=float)
        return system.compiled_forces.element_rates(self, tree, q, np.asarray(qd, float),
                                                    float(t), z)


class Kernels(NamedTuple):
    """The compiled form of one element kind, registered by its module in a module-level
    ``KERNELS`` tuple (:mod:`pipeline.dynamics.forces.compiled` collects them): its element
    classes (each with the ``KIND`` and the YAML ``TYPE`` of the kind) and its numba
    kernels, each with one signature for every kind (d the flat ForceData, e the element's
    row, factor (2F,) the history factors, z (nz,) the elements' states):

    - ``potential(e, q, A, dA, d) -> V`` J of the conservative part;
    - ``push(e, z, length, rate, factor, d) -> (f, f_nc)`` N, for a line element (its
      force driving its markers apart, and that force's non-conservative part);
    - ``force(e, q, v, z, A, dA, factor, d, Q, Qnc)`` adding Q and its non-conservative
      part, for any other element;
    - ``loads(e, q, v, z, A, dA, factor, d, rows) -> k`` writing k rows (2, 10) of
      physical loads (``markers.load_row``), for an element not on a coordinate;
    - ``rates(e, q, v, z, A, dA, factor, d, zd)`` writing its own states' rates into zd.
    """

    classes: tuple
    potential: Any
    push: Any = None
    force: Any = None
    loads: Any = None
    rates: Any = None

    @property
    def kind(self) -> int:
        return self.classes[0].KIND


class CoordinateElement(ForceElement):
    """Base of the elements acting on one coordinate, named by ``coordinate`` (a joint
    spring, a joint force, a joint limit): their validation. Their force is transmitted
    through the coordinate's joint: they have no loads of their own."""

    coordinate: str

    def validate(self, system) -> None:
        check_coordinate(system, self.coordinate, self.name)


class LineElement(ForceElement):
    """Base of the elements acting along the line from ``marker_a`` to ``marker_b`` (a
    spring-damper, a line force, a hydraulic cylinder): their validation. Their compiled
    form is a push along the line (:attr:`Kernels.push`)."""

    marker_a: tuple[str, str]
    marker_b: tuple[str, str]

    def validate(self, system) -> None:
        check_marker(system, self.marker_a, self.name, "marker_a")
        check_marker(system, self.marker_b, self.name, "marker_b")
