"""Spring-dampers: point to point (linear or by force-deflection table) and on a joint coordinate.

Point to point between markers a and b: length l = |R_b - R_a|, tension
f = f(l) + c l' (positive pulls the markers together), so
Q = -f dl/dq and V = int f(l) dl. Joint spring on coordinate q_k:
Q_k = -k (q_k - q0) - c q_k'.

Examples
--------
>>> s = SpringDamper("s", ("ground", "body"), ("arm", "tip"), stiffness=100.0, free_length=0.5)
>>> s.conservative  # no damper: Q = -dV/dq
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

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
    nonnegative,
)
from pipeline.dynamics.forces.markers import line_geometry

__all__ = ["JointSpringDamper", "SpringDamper", "TableSpringDamper"]


@dataclass(frozen=True)
class SpringDamper(CompiledElement, LineElement):
    """Linear spring (N/m, free length m, preload N) and damper (N s/m) between two markers."""

    name: str
    marker_a: tuple[str, str]
    marker_b: tuple[str, str]
    stiffness: float = 0.0
    free_length: float = 0.0
    damping: float = 0.0
    preload: float = 0.0

    #: kind of the compiled form (:mod:`pipeline.dynamics.forces.compiled`)
    KIND: ClassVar[int] = 2
    TYPE: ClassVar[str] = "spring_damper"

    def __post_init__(self):
        nonnegative(self.stiffness, self.name, "stiffness")
        nonnegative(self.damping, self.name, "damping")
        nonnegative(self.free_length, self.name, "free_length")

    def pack(self, mech, markers) -> tuple:
        """(ints (4,), par (6,), table rows or None) of the compiled form."""
        return ([markers.add(self.marker_a), markers.add(self.marker_b), 0, 0],
                [self.stiffness, self.free_length, self.damping, self.preload, 0.0, 0.0],
                None)

    @property
    def conservative(self) -> bool:
        return self.damping == 0.0


@dataclass(frozen=True)
class TableSpringDamper(SpringDamper):
    """Spring given by a force-deflection table (piecewise linear, extrapolated linearly
    from the end segments) plus a linear damper.

    deflection : (k,) l - free_length, m, strictly increasing; force : (k,) tension, N.
    """

    deflection: tuple = ()
    force: tuple = ()
    KIND: ClassVar[int] = 4
    TYPE: ClassVar[str] = "table_spring_damper"

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows (k, 3): deflection m, tension N, int_x0^x f dx J)."""
        xs, fs = np.asarray(self.deflection), np.asarray(self.force)
        cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (fs[1:] + fs[:-1]) * np.diff(xs))])
        return ([markers.add(self.marker_a), markers.add(self.marker_b), 0, xs.size],
                [0.0, self.free_length, self.damping, 0.0, 0.0, 0.0],
                np.column_stack([xs, fs, cumulative]))

    def __post_init__(self):
        super().__post_init__()
        x = validate_array(self.deflection, (-1,), f"force element '{self.name}': deflection")
        f = validate_array(self.force, (x.size,), f"force element '{self.name}': force")
        if x.size < 2 or np.any(np.diff(x) <= 0):
            raise ConfigError(f"force element '{self.name}': deflection: expected at least "
                              f"2 strictly increasing values, got {x.tolist()}")
        object.__setattr__(self, "deflection", tuple(x))
        object.__setattr__(self, "force", tuple(f))


@dataclass(frozen=True)
class JointSpringDamper(CompiledElement, CoordinateElement):
    """Spring k (N m/rad or N/m) about free value q0 and damper c on one coordinate (its
    force is transmitted through the joint of ``coordinate``: no loads of its own)."""

    name: str
    coordinate: str
    stiffness: float = 0.0
    free_value: float = 0.0
    damping: float = 0.0

    KIND: ClassVar[int] = 0
    TYPE: ClassVar[str] = "joint_spring_damper"

    def __post_init__(self):
        nonnegative(self.stiffness, self.name, "stiffness")
        nonnegative(self.damping, self.name, "damping")

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        return ([mech.index(self.coordinate), 0, 0, 0],
                [self.stiffness, self.free_value, self.damping, 0.0, 0.0, 0.0], None)

    @property
    def conservative(self) -> bool:
        return self.damping == 0.0


# --------------------------------------------------------------------------- compiled forms
# The physics of these elements, once: element e's generalized force added to Q and its
# non-conservative part to Qnc, its push along its line (a line element's: the force
# driving its markers apart, N, and that push's non-conservative part), or its potential
# energy, from the flat ForceData d (pipeline.dynamics.forces.markers). The numpy oracle
# is tests/dynamics/forces_numpy.py.

@njit(cache=True)
def joint_spring_force(e, q, v, z, A, dA, factor, d, Q, Qnc):
    i = d.ints[e, 0]
    Q[i] += -d.par[e, 0] * (q[i] - d.par[e, 1]) - d.par[e, 2] * v[i]
    Qnc[i] += -d.par[e, 2] * v[i]


@njit(cache=True)
def joint_spring_potential(e, q, A, dA, d):
    x = q[d.ints[e, 0]] - d.par[e, 1]
    return 0.5 * d.par[e, 0] * x * x


@njit(cache=True)
def line_spring_push(e, z, length, rate, factor, d):
    """(-(preload + k (l - l0) + c l'), -c l'): the spring pulls its markers together."""
    damper = d.par[e, 2] * rate
    return -(d.par[e, 3] + d.par[e, 0] * (length - d.par[e, 1]) + damper), -damper


@njit(cache=True)
def line_spring_potential(e, q, A, dA, d):
    length, _ = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
    x = length - d.par[e, 1]
    return d.par[e, 3] * x + 0.5 * d.par[e, 0] * x * x


@njit(cache=True)
def _table_segment(d, e, x):
    """(first row k of the segment holding deflection x, its slope f' N/m)."""
    start, count = d.ints[e, 2], d.ints[e, 3]
    k = 0
    while k < count - 2 and d.table[start + k + 1, 0] < x:
        k += 1
    r = start + k
    return r, (d.table[r + 1, 1] - d.table[r, 1]) / (d.table[r + 1, 0] - d.table[r, 0])


@njit(cache=True)
def _table_integral(d, e, x):
    """int f dx from the table's first row to deflection x, J (exact: f is piecewise
    linear)."""
    r, slope = _table_segment(d, e, x)
    dx = x - d.table[r, 0]
    return d.table[r, 2] + d.table[r, 1] * dx + 0.5 * slope * dx * dx


@njit(cache=True)
def table_spring_push(e, z, length, rate, factor, d):
    """(-(f(l - l0) + c l'), -c l') with f from the table."""
    x = length - d.par[e, 1]
    r, slope = _table_segment(d, e, x)
    damper = d.par[e, 2] * rate
    return -(d.table[r, 1] + slope * (x - d.table[r, 0]) + damper), -damper


@njit(cache=True)
def table_spring_potential(e, q, A, dA, d):
    length, _ = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
    return _table_integral(d, e, length - d.par[e, 1]) - _table_integral(d, e, 0.0)


#: the compiled forms of this module's kinds (:class:`~.base.Kernels`)
KERNELS = (
    Kernels((JointSpringDamper,), joint_spring_potential, force=joint_spring_force),
    Kernels((SpringDamper,), line_spring_potential, push=line_spring_push),
    Kernels((TableSpringDamper,), table_spring_potential, push=table_spring_push),
)
