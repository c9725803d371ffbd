"""Joint limits: a stiff spring and damper that act on a coordinate beyond its range (a
slewing ring's end stops, a prismatic guide's end, a cylinder modelled as a prescribed
stroke that must not leave its barrel).

On coordinate q_k with range [lower, upper], the penetration is x = q_k - upper above
the range, x = q_k - lower below it, and 0 inside. The element's force is
Q_k = -k x - c q_k' while x != 0 and 0 inside (a Kelvin-Voigt contact: the damper acts
only in contact, so the force jumps by c q_k' as contact begins, and may pull briefly
before it ends), and its potential V = k x^2 / 2. Like a joint spring its force is
transmitted through the joint: it has no loads of its own.

This module is the worked example of ``docs/force_elements.md``: an element kind added to
the package by this one file (its class, kernels and ``KERNELS`` entry).

Examples
--------
>>> stop = JointLimit("stop", "slew.theta", upper=1.5, stiffness=1e7)
>>> stop.conservative  # no damper: Q = -dV/dq
True
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import ClassVar

from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.core.errors import ConfigError
from pipeline.dynamics.forces.base import (
    CompiledElement,
    CoordinateElement,
    Kernels,
    nonnegative,
)

__all__ = ["JointLimit"]


@dataclass(frozen=True)
class JointLimit(CompiledElement, CoordinateElement):
    """End stops on one coordinate: outside [lower, upper] (m or rad; None: no stop on
    that side) a spring ``stiffness`` (N/m or N m/rad) and a damper ``damping`` (N s/m or
    N m s/rad) push it back."""

    name: str
    coordinate: str
    lower: float | None = None
    upper: float | None = None
    stiffness: float = 0.0
    damping: float = 0.0

    #: kind of the compiled form (:mod:`pipeline.dynamics.forces.compiled`)
    KIND: ClassVar[int] = 9
    TYPE: ClassVar[str] = "joint_limit"

    def __post_init__(self):
        nonnegative(self.stiffness, self.name, "stiffness")
        nonnegative(self.damping, self.name, "damping")
        for field in ("lower", "upper"):
            v = getattr(self, field)
            if v is not None and (isinstance(v, bool) or not isinstance(v, numbers.Real)
                                  or not math.isfinite(v)):
                raise ConfigError(f"force element '{self.name}': {field}: expected a finite "
                                  f"value or none, got {v!r}")
        if self.lower is None and self.upper is None:
            raise ConfigError(f"force element '{self.name}': expected a lower or an upper "
                              "limit (or both)")
        if self.lower is not None and self.upper is not None and self.lower >= self.upper:
            raise ConfigError(f"force element '{self.name}': lower: expected below upper "
                              f"({self.upper}), got {self.lower}")

    def pack(self, mech, markers) -> tuple:
        """(ints, par: stiffness, lower, upper, damping; table rows or None)."""
        lower = -math.inf if self.lower is None else float(self.lower)
        upper = math.inf if self.upper is None else float(self.upper)
        return ([mech.index(self.coordinate), 0, 0, 0],
                [float(self.stiffness), lower, upper, float(self.damping), 0.0, 0.0], None)

    @property
    def conservative(self) -> bool:
        return self.damping == 0.0


# --------------------------------------------------------------------------- compiled form
# The element's physics, once (the signatures of base.Kernels): its penetration of the
# range, its force on the coordinate and its potential, from the flat ForceData d.

@njit(cache=True)
def penetration(e, q, d):
    """x (m or rad): q_k - upper above the range, q_k - lower below it, 0 inside."""
    x = q[d.ints[e, 0]]
    if x > d.par[e, 2]:
        return x - d.par[e, 2]
    if x < d.par[e, 1]:
        return x - d.par[e, 1]
    return 0.0


@njit(cache=True)
def limit_force(e, q, v, z, A, dA, factor, d, Q, Qnc):
    x = penetration(e, q, d)
    if x != 0.0:
        i = d.ints[e, 0]
        damper = -d.par[e, 3] * v[i]
        Q[i] += -d.par[e, 0] * x + damper
        Qnc[i] += damper


@njit(cache=True)
def limit_potential(e, q, A, dA, d):
    x = penetration(e, q, d)
    return 0.5 * d.par[e, 0] * x * x


#: the compiled form of this module's kind (:class:`~.base.Kernels`)
KERNELS = (Kernels((JointLimit,), limit_potential, force=limit_force),)
