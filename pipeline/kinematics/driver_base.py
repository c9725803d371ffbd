"""Driver contract and helpers shared by :mod:`pipeline.kinematics.drivers`.

:class:`Driver` is the base of every prescribed-motion driver; :class:`SumDriver`
and :class:`Constant` live here because ``Driver.__add__`` builds them. Users import from
:mod:`pipeline.kinematics.drivers`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from pipeline.core.errors import ConfigError

__all__ = ["Constant", "Driver", "SumDriver"]


# --------------------------------------------------------------------------- helpers
def out(t, y):
    """Float for scalar ``t``, float array of ``t``'s shape otherwise."""
    if np.ndim(t) == 0:
        return float(y)
    return np.broadcast_to(np.asarray(y, dtype=float), np.shape(t)).copy()


def number(d: dict, key: str, where: str, default: float | None = None) -> float:
    """Read ``d[key]`` as a finite float (``float()`` only, never ``eval``)."""
    if key not in d:
        if default is None:
            raise ConfigError(f"{where}.{key}: required field is missing")
        return default
    return finite_float(d[key], f"{where}.{key}")


def finite_float(raw: Any, name: str) -> float:
    """``raw`` as a finite float; numeric strings are parsed by ``float`` only."""
    if isinstance(raw, bool) or not isinstance(raw, (int, float, str, np.number)):
        raise ConfigError(f"{name}: expected a number, got {raw!r}")
    try:
        v = float(raw)
    except ValueError:
        raise ConfigError(f"{name}: expected a number, got {raw!r}") from None
    if not math.isfinite(v):
        raise ConfigError(f"{name}: expected a finite number, got {raw!r}")
    return v


def check_keys(d: Any, allowed: set[str], where: str) -> None:
    if not isinstance(d, dict):
        raise ConfigError(f"{where}: expected a mapping with a 'type' field, got {d!r}")
    extra = sorted(set(d) - allowed - {"type"})
    if extra:
        raise ConfigError(f"{where}: unknown field(s) {extra}; allowed: {sorted(allowed)}")


# --------------------------------------------------------------------------- base
class Driver:
    """Contract of every driver (subclasses are frozen dataclasses).

    Subclasses implement ``value``, ``rate`` and ``accel`` and a classmethod
    ``from_dict(d, where, base_dir=None)``; ``rate`` and ``accel`` are the exact
    first and second time derivatives of ``value`` wherever it is smooth.
    """

    type_name: ClassVar[str] = ""

    def value(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def rate(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def accel(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def state(self, t: float) -> tuple[float, float, float]:
        """(value, rate, acceleration) at one time t, s; subclasses may do it in one pass
        (a dynamics run asks for all three at every time step)."""
        return float(self.value(t)), float(self.rate(t)), float(self.accel(t))

    def breaks(self) -> tuple[float, ...]:
        """The times, s, where the rate or the acceleration may jump (knots of a table, the
        start of a ramp); ``rate`` and ``accel`` give the values just after them. A
        transient run ends a step on each and starts the method afresh there (an
        integrator of second order stays so only between such places), and where the
        rate jumps the machine takes the impulse that jump needs. Default: none."""
        return ()

    def __add__(self, other) -> SumDriver:
        if isinstance(other, (int, float)) and not isinstance(other, bool):
            other = Constant(float(other))
        if not isinstance(other, Driver):
            return NotImplemented
        left = self.terms if isinstance(self, SumDriver) else (self,)
        right = other.terms if isinstance(other, SumDriver) else (other,)
        return SumDriver(left + right)

    def __radd__(self, other) -> SumDriver:
        # sum([d1, d2]) starts from 0: adding 0 must not create a spurious term
        if isinstance(other, (int, float)) and not isinstance(other, bool) and other == 0:
            return self if isinstance(self, SumDriver) else SumDriver((self,))
        return self.__add__(other)


@dataclass(frozen=True)
class Constant(Driver):
    """q(t) = level (dict key ``value``)."""

    level: float
    type_name: ClassVar[str] = "constant"

    def value(self, t):
        return out(t, self.level)

    def rate(self, t):
        return out(t, 0.0)

    def accel(self, t):
        return out(t, 0.0)

    def state(self, t: float) -> tuple[float, float, float]:
        return float(self.level), 0.0, 0.0

    @classmethod
    def from_dict(cls, d: dict, where: str, base_dir: Path | None = None) -> Constant:
        check_keys(d, {"value"}, where)
        return cls(number(d, "value", where))


# --------------------------------------------------------------------------- sums
@dataclass(frozen=True)
class SumDriver(Driver):
    """Sum of drivers: value, rate and acceleration add term by term.

    Its YAML form (``type: sum``, ``terms: [...]``) is read by
    :func:`pipeline.kinematics.drivers.driver_from_dict`, which knows every term type.
    """

    terms: tuple[Driver, ...]
    type_name: ClassVar[str] = "sum"

    def __post_init__(self):
        if not self.terms or not all(isinstance(d, Driver) for d in self.terms):
            raise ConfigError("sum.terms: expected a non-empty tuple of drivers")

    def _total(self, t, method: str):
        return out(t, sum(np.asarray(getattr(d, method)(t), dtype=float) for d in self.terms))

    def value(self, t):
        return self._total(t, "value")

    def rate(self, t):
        return self._total(t, "rate")

    def accel(self, t):
        return self._total(t, "accel")

    def breaks(self) -> tuple[float, ...]:
        return tuple(sorted({t for d in self.terms for t in d.breaks()}))
