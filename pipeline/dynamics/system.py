"""The multibody system the dynamics layer works on (a description, no state).

Contract shared by the equations of motion (``pipeline.dynamics`` mass
matrix, velocity terms, gravity, elastic forces), the force elements
(``pipeline.dynamics.forces``) and the analyses:

* ``mechanism`` is a :class:`pipeline.kinematics.Mechanism`; q follows its
  coordinate layout (joint variables, then the modal coordinates of every
  flexible link).
* ``bodies`` maps a link name to its :class:`BodyMass` in that link's body
  frame; a link without an entry is massless (ground, cylinder rods one
  chooses to neglect).
* ``forces`` are force elements with the protocol of
  :class:`pipeline.dynamics.forces.base.ForceElement` (generalized force by
  virtual work, potential energy, dissipated power).
* ``drivers`` prescribe coordinates by name (``"lift.s"`` -> driver with
  ``value(t)``, ``rate(t)``, ``accel(t)``); those become rheonomic constraints
  and their reactions are the actuator forces.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_positive, validate_array


def rigid_C(mass: float, com: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """(4, 4) C = int rho r r^T dV of a rigid body.

    Parameters
    ----------
    mass : kg. com : (3,) centre of mass in the body frame, m.
    inertia : (3, 3) inertia tensor about the centre of mass, body axes, kg m^2.

    Examples
    --------
    >>> C = rigid_C(2.0, np.array([1.0, 0, 0]), np.diag([1.0, 1.0, 1.0]))
    >>> float(C[3, 3]), float(C[0, 3]), float(C[0, 0])
    (2.0, 2.0, 2.5)
    """
    com = np.asarray(com, float)
    inertia = np.asarray(inertia, float)
    S = 0.5 * np.trace(inertia) * np.eye(3) - inertia + mass * np.outer(com, com)
    C = np.zeros((4, 4))
    C[:3, :3] = S
    C[:3, 3] = C[3, :3] = mass * com
    C[3, 3] = mass
    return C


@dataclass(frozen=True)
class BodyMass:
    """Mass and elastic data of one link in its body frame (DESIGN §2).

    Attributes
    ----------
    C : (4, 4) kg, kg m, kg m^2.
    Cp : (m, 4, 4) C'_a.
    Cpp : (m, m, 4, 4) C''_ab.
    stiffness : (m, m) modal stiffness, N m / (modal unit)^2.
    damping : (m, m) modal damping matrix (e.g. diag(2 zeta omega) for
        mass-normalised modes), N m s.
    second_order_moments : (m, m, 4, 3) G with the second-order part of the mass moments,
        int rho xb u2^T dV = sum_ab eta_a eta_b G_ab / 2 (xb = [x, y, z, 1] body
        coordinates, u2 the second-order displacement, body axes; kg m^2 and kg m per
        modal unit^2), or (0, 0, 4, 3): none (linear modes). It is the mass moving
        towards the reference as the link bends; with it the link's accelerations, spin
        and gravity stiffen its modes, conservatively
        (:func:`pipeline.dynamics.mass_matrix.link_terms`).
    """

    C: np.ndarray
    Cp: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))
    Cpp: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 4, 4)))
    stiffness: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    damping: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    second_order_moments: np.ndarray = field(
        default_factory=lambda: np.zeros((0, 0, 4, 3)))

    def __post_init__(self) -> None:
        G, m = np.asarray(self.second_order_moments, dtype=float), self.n_modes
        if G.size and G.shape != (m, m, 4, 3):
            raise ConfigError(f"second_order_moments: expected shape ({m}, {m}, 4, 3) for "
                              f"{m} modes, got {G.shape}")
        object.__setattr__(self, "second_order_moments",
                           G if G.size else np.zeros((0, 0, 4, 3)))

    @property
    def n_modes(self) -> int:
        return int(self.Cp.shape[0])

    @classmethod
    def rigid(cls, mass: float, com, inertia) -> BodyMass:
        """Rigid body from mass (kg), centre of mass (3,) m and inertia (3, 3) kg m^2."""
        check_positive(mass, "mass")
        com = validate_array(com, (3,), "center_of_mass")
        inertia = validate_array(inertia, (3, 3), "inertia")
        with np.errstate(over="ignore", invalid="ignore"):
            C = rigid_C(mass, com, inertia)
        if not np.isfinite(C).all():
            raise ConfigError(f"mass properties overflow (mass {mass:g} kg, centre of mass "
                              f"{com.tolist()} m): values too large for double precision")
        return cls(C=C)


@dataclass(frozen=True)
class System:
    """Mechanism + masses + forces + drivers + gravity (SI units)."""

    mechanism: Any  # pipeline.kinematics.Mechanism
    bodies: Mapping[str, BodyMass]
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    forces: tuple = ()
    drivers: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "bodies", MappingProxyType(dict(self.bodies)))
        object.__setattr__(self, "drivers", MappingProxyType(dict(self.drivers)))
        object.__setattr__(self, "gravity", validate_array(self.gravity, (3,), "gravity"))
        object.__setattr__(self, "forces", tuple(self.forces))

    @cached_property
    def modal_stiffness_damping(self) -> tuple[np.ndarray, np.ndarray]:
        """(K, D), each (n, n): the flexible bodies' modal stiffness and damping placed on
        their modal coordinates (zero elsewhere), N m and N m s per modal unit^2."""
        n = self.mechanism.n
        K, D = np.zeros((n, n)), np.zeros((n, n))
        for _, body, idx in self.mass_links:
            if idx.size:
                K[np.ix_(idx, idx)] = body.stiffness
                if body.damping.size:
                    D[np.ix_(idx, idx)] = body.damping
        for a in (K, D):
            a.setflags(write=False)
        return K, D

    @cached_property
    def state_slices(self) -> tuple[tuple[Any, slice], ...]:
        """(element, its slice of the states z) of every force element with states of its
        own (pipeline.dynamics.forces.base, contract rule 7), in the order of ``forces``."""
        out, k = [], 0
        for f in self.forces:
            n = len(getattr(f, "STATES", ()))
            if n:
                out.append((f, slice(k, k + n)))
                k += n
        return tuple(out)

    def states_of(self, f, z) -> tuple:
        """The trailing argument of force element f's methods: (its slice of the states z
        (nz,), or None where the caller has none,) for an element with states, () else."""
        for g, sl in self.state_slices:
            if g is f:
                return (None if z is None else z[sl],)
        return ()

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names ``<element>.<state>`` of the elements' states z, in order."""
        return tuple(f"{f.name}.{x}" for f, _ in self.state_slices for x in f.STATES)

    @property
    def state_units(self) -> tuple[str, ...]:
        """The units of the elements' states z, in the order of ``state_names``."""
        return tuple(u for f, _ in self.state_slices for u in f.STATE_UNITS)

    def initial_states(self, q=None, t: float = 0.0) -> np.ndarray:
        """(nz,) every element's states at the start of a run at rest at q (n,): those an
        element leaves open (NaN: a hydraulic cylinder's ``hold`` pressure) are the ones
        that hold the machine there (:func:`pipeline.dynamics.held_states.held_states`)."""
        parts = [np.asarray(f.initial_states(), dtype=float) for f, _ in self.state_slices]
        z = np.concatenate(parts) if parts else np.zeros(0)
        if np.isnan(z).any():
            from pipeline.dynamics.held_states import held_states

            z = held_states(self, q, t, z)
        return z

    def state_scales(self) -> np.ndarray:
        """(nz,) the size of a meaningful change of each state."""
        parts = [np.asarray(f.state_scales(), dtype=float) for f, _ in self.state_slices]
        return np.concatenate(parts) if parts else np.zeros(0)

    @cached_property
    def gravity4(self) -> np.ndarray:
        """(4,) gravity as a homogeneous direction [g, 0], m/s^2."""
        return np.append(self.gravity, 0.0)

    @cached_property
    def compiled_masses(self):
        """Flat mass data for :mod:`pipeline.dynamics.compiled` (built on first use)."""
        from pipeline.dynamics.compiled import compile_masses  # numba loads only if used
        return compile_masses(self)

    @cached_property
    def compiled_forces(self):
        """The force elements in compiled form (:class:`pipeline.dynamics.forces.compiled.
        CompiledForces`): their physics, once, for every analysis (built on first use)."""
        from pipeline.dynamics.forces.compiled import CompiledForces  # numba: only if used
        return CompiledForces.of(self)

    @cached_property  # used at every evaluation of the equations of motion
    def mass_links(self) -> tuple[tuple[int, BodyMass, np.ndarray], ...]:
        """(link index, BodyMass, modal indices in q) of every link that has mass."""
        mech = self.mechanism
        index = {name: mech.link_index(name) for name in self.bodies}
        return tuple((index[name], body, mech.modal_index[index[name]])
                     for name, body in self.bodies.items())
