"""Prescribed motion of a joint coordinate as a function of time.

A driver is a frozen dataclass with ``value(t)``, ``rate(t)`` and ``accel(t)``
(SI units of the driven coordinate: rad or m, per s, per s^2; ``t`` in s).
Each returns a float for a scalar ``t`` and an array of ``t``'s shape for an
array. Drivers add with ``+`` (a :class:`SumDriver`); a plain number added to
a driver becomes a :class:`Constant`.

The YAML layer passes plain dicts to :func:`driver_from_dict`, which looks the
``type`` up in :data:`DRIVERS`. User text is never evaluated: numbers are
converted with ``float`` only and checked to be finite.

Tables (:class:`Table`) hold their end values outside their time range
(rate and acceleration 0 there), so a cylinder stroke table keeps the cylinder
parked at its last value instead of extrapolating past its stroke limits.

Examples
--------
>>> d = driver_from_dict({"type": "smooth_step", "t0": 0, "t1": 2, "v0": 0.3, "v1": 0.9})
>>> round(d.value(1.0), 12)
0.6
>>> (d + Constant(1.0)).value(3.0)  # doctest: +ELLIPSIS
1.9...
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.kinematics.driver_base import Constant, Driver, SumDriver, check_keys, number, out
from pipeline.kinematics.driver_table import Table, load_table_csv

__all__ = [
    "DRIVERS",
    "Constant",
    "Driver",
    "Harmonic",
    "Ramp",
    "SmoothStep",
    "SpinUp",
    "SumDriver",
    "Table",
    "driver_from_dict",
    "load_table_csv",
]


@dataclass(frozen=True)
class Ramp(Driver):
    """q = v0 for t < t0, q = v0 + slope·(t − t0) from t0 on (dict key ``rate``).

    The rate jumps at t0 (value is C0 there); ``rate(t0)`` returns ``slope``.
    """

    t0: float
    slope: float
    v0: float = 0.0
    type_name: ClassVar[str] = "ramp"

    def value(self, t):
        tt = np.asarray(t, dtype=float)
        return out(t, self.v0 + self.slope * np.maximum(tt - self.t0, 0.0))

    def rate(self, t):
        tt = np.asarray(t, dtype=float)
        return out(t, np.where(tt >= self.t0, self.slope, 0.0))

    def accel(self, t):
        return out(t, 0.0)

    def breaks(self) -> tuple[float, ...]:
        return (float(self.t0),)

    @classmethod
    def from_dict(cls, d: dict, where: str, base_dir: Path | None = None) -> Ramp:
        check_keys(d, {"t0", "rate", "v0"}, where)
        return cls(number(d, "t0", where, 0.0), number(d, "rate", where),
                   number(d, "v0", where, 0.0))


_SHAPES = ("quintic", "cosine")


@dataclass(frozen=True)
class SmoothStep(Driver):
    """From v0 (t <= t0) to v1 (t >= t1) along s(τ), τ = (t − t0)/(t1 − t0).

    ``shape="quintic"``: s = 10τ³ − 15τ⁴ + 6τ⁵, C2 (rate and acceleration are 0
    at both ends), the default because accelerations feed the dynamics.
    ``shape="cosine"``: s = (1 − cos πτ)/2, C1 only (acceleration jumps at t0, t1).
    """

    t0: float
    t1: float
    v0: float
    v1: float
    shape: str = "quintic"
    type_name: ClassVar[str] = "smooth_step"

    def __post_init__(self):
        if not self.t1 > self.t0:
            raise ConfigError(f"smooth_step.t1: expected t1 > t0, got t0={self.t0}, t1={self.t1}")
        if self.shape not in _SHAPES:
            raise ConfigError(f"smooth_step.shape: expected one of {_SHAPES}, got {self.shape!r}")

    def _tau(self, t):
        T = self.t1 - self.t0
        tau = (np.asarray(t, dtype=float) - self.t0) / T
        inside = (tau > 0.0) & (tau < 1.0)
        return np.clip(tau, 0.0, 1.0), inside, T

    def _s(self, tau, k: int):
        """k-th derivative of s with respect to τ."""
        if self.shape == "quintic":
            return [tau**3 * (10 - 15 * tau + 6 * tau**2),
                    30 * tau**2 * (1 - tau) ** 2,
                    60 * tau * (1 - tau) * (1 - 2 * tau)][k]
        c = np.pi
        return [0.5 * (1 - np.cos(c * tau)), 0.5 * c * np.sin(c * tau),
                0.5 * c**2 * np.cos(c * tau)][k]

    def value(self, t):
        tau, _, _ = self._tau(t)
        return out(t, self.v0 + (self.v1 - self.v0) * self._s(tau, 0))

    def state(self, t: float) -> tuple[float, float, float]:
        T = self.t1 - self.t0
        tau = min(max((float(t) - self.t0) / T, 0.0), 1.0)
        inside = 0.0 < tau < 1.0
        dv = self.v1 - self.v0
        s0, s1, s2 = (self._s(tau, k) for k in range(3))
        return (self.v0 + dv * float(s0), dv * float(s1) / T if inside else 0.0,
                dv * float(s2) / T**2 if inside else 0.0)

    def rate(self, t):
        tau, inside, T = self._tau(t)
        return out(t, np.where(inside, (self.v1 - self.v0) * self._s(tau, 1) / T, 0.0))

    def accel(self, t):
        tau, inside, T = self._tau(t)
        return out(t, np.where(inside, (self.v1 - self.v0) * self._s(tau, 2) / T**2, 0.0))

    def breaks(self) -> tuple[float, ...]:
        return () if self.shape == "quintic" else (float(self.t0), float(self.t1))

    @classmethod
    def from_dict(cls, d: dict, where: str, base_dir: Path | None = None) -> SmoothStep:
        check_keys(d, {"t0", "t1", "v0", "v1", "shape"}, where)
        t0, t1 = number(d, "t0", where), number(d, "t1", where)
        if not t1 > t0:
            raise ConfigError(f"{where}.t1: expected t1 > t0, got t0={t0}, t1={t1}")
        shape = d.get("shape", "quintic")
        if shape not in _SHAPES:
            raise ConfigError(f"{where}.shape: expected one of {_SHAPES}, got {shape!r}")
        return cls(t0, t1, number(d, "v0", where), number(d, "v1", where), shape)


@dataclass(frozen=True)
class Harmonic(Driver):
    """q = offset + amplitude · sin(2π·frequency·t + phase); frequency in Hz, phase in rad."""

    amplitude: float
    frequency: float
    phase: float = 0.0
    offset: float = 0.0
    type_name: ClassVar[str] = "harmonic"

    def _arg(self, t):
        return 2 * np.pi * self.frequency * np.asarray(t, dtype=float) + self.phase

    def value(self, t):
        return out(t, self.offset + self.amplitude * np.sin(self._arg(t)))

    def rate(self, t):
        w = 2 * np.pi * self.frequency
        return out(t, self.amplitude * w * np.cos(self._arg(t)))

    def accel(self, t):
        w = 2 * np.pi * self.frequency
        return out(t, -self.amplitude * w**2 * np.sin(self._arg(t)))

    @classmethod
    def from_dict(cls, d: dict, where: str, base_dir: Path | None = None) -> Harmonic:
        check_keys(d, {"amplitude", "frequency", "phase", "offset"}, where)
        f = number(d, "frequency", where)
        if f < 0:
            raise ConfigError(f"{where}.frequency: expected a value >= 0 Hz, got {f}")
        return cls(number(d, "amplitude", where), f, number(d, "phase", where, 0.0),
                   number(d, "offset", where, 0.0))


@dataclass(frozen=True)
class SpinUp(Driver):
    """Spin-up to a final rate: q' = rate (tau - sin(2 pi tau) / (2 pi)), tau = t / t1, for
    0 <= t <= t1, then q' = rate; q(0) = v0 (the smooth law of Kane, Ryan and Banerjee's
    spinning-beam test: the acceleration rises from and returns to zero)."""

    t1: float
    slope: float
    v0: float = 0.0
    type_name: ClassVar[str] = "spin_up"

    def __post_init__(self):
        if not self.t1 > 0:
            raise ConfigError(f"spin_up.t1: expected t1 > 0 s, got {self.t1}")

    def value(self, t):
        tt = np.asarray(t, dtype=float)
        T, w = self.t1, self.slope
        c = T / (2 * np.pi)
        ramp = w / T * (0.5 * tt**2 + c**2 * (np.cos(tt / c) - 1.0))
        return out(t, self.v0 + np.where(tt <= 0, 0.0, np.where(tt < T, ramp,
                                                                 w * (tt - 0.5 * T))))

    def rate(self, t):
        tt = np.asarray(t, dtype=float)
        T, w = self.t1, self.slope
        ramp = w / T * (tt - T / (2 * np.pi) * np.sin(2 * np.pi * tt / T))
        return out(t, np.where(tt <= 0, 0.0, np.where(tt < T, ramp, w)))

    def accel(self, t):
        tt = np.asarray(t, dtype=float)
        T, w = self.t1, self.slope
        inside = (tt > 0) & (tt < T)
        return out(t, np.where(inside, w / T * (1.0 - np.cos(2 * np.pi * tt / T)), 0.0))

    @classmethod
    def from_dict(cls, d: dict, where: str, base_dir: Path | None = None) -> SpinUp:
        check_keys(d, {"t1", "rate", "v0"}, where)
        t1 = number(d, "t1", where)
        if not t1 > 0:
            raise ConfigError(f"{where}.t1: expected t1 > 0 s, got {t1}")
        return cls(t1, number(d, "rate", where), number(d, "v0", where, 0.0))


#: Driver classes keyed by the YAML ``type`` string.
DRIVERS: dict[str, type[Driver]] = {
    c.type_name: c for c in (Constant, Ramp, SmoothStep, SpinUp, Harmonic, Table, SumDriver)
}


def driver_from_dict(d: dict, where: str = "driver", base_dir: str | Path | None = None) -> Driver:
    """Build a driver from a plain dict (as parsed from YAML); ``d`` is not modified.

    Parameters
    ----------
    d : dict
        ``{"type": <one of DRIVERS>, ...fields}``.
    where : str
        Prefix naming the dict in error messages, e.g. ``"drivers[2]"``.
    base_dir : path, optional
        Folder that relative table ``file`` paths are resolved against.

    Raises
    ------
    ConfigError
        Unknown type, unknown or missing field, non-numeric or non-finite value.

    Examples
    --------
    >>> driver_from_dict({"type": "ramp", "t0": 1.0, "rate": 0.5}).value(3.0)
    1.0
    """
    if not isinstance(d, dict):
        raise ConfigError(f"{where}: expected a mapping with a 'type' field, got {d!r}")
    kind = d.get("type")
    if kind not in DRIVERS:
        raise ConfigError(f"{where}.type: expected one of {sorted(DRIVERS)}, got {kind!r}")
    base = None if base_dir is None else Path(base_dir)
    if DRIVERS[kind] is SumDriver:  # a composite: its terms are drivers of any type
        return _sum_from_dict(d, where, base)
    return DRIVERS[kind].from_dict(d, where, base)


def _sum_from_dict(d: dict, where: str, base_dir: Path | None) -> SumDriver:
    check_keys(d, {"terms"}, where)
    terms = d.get("terms")
    if not isinstance(terms, (list, tuple)) or not terms:
        raise ConfigError(f"{where}.terms: expected a non-empty list of drivers, got {terms!r}")
    return SumDriver(tuple(driver_from_dict(x, f"{where}.terms[{i}]", base_dir)
                           for i, x in enumerate(terms)))
