"""Boundary checks: ``check_*`` raise :class:`ConfigError`, ``validate_*`` return a
normalised value. Every message names the offending field via ``name``."""

from __future__ import annotations

import numpy as np

from pipeline.core.errors import ConfigError


def check_number(value, name: str) -> None:
    """Raise ``ConfigError`` unless ``value`` is a number or nested lists of numbers: a
    boolean (``true`` is not 1 m) or a string (``'0.008'`` is text in YAML) is refused,
    not coerced. Numpy arrays of numbers pass.

    Examples
    --------
    >>> check_number([1, 2.5], "origin")
    """
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "biufc" and value.dtype.kind != "b":
            return
        raise ConfigError(f"{name}: expected numbers, got an array of {value.dtype}")
    if isinstance(value, (list, tuple)):
        for v in value:
            check_number(v, name)
        return
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        what = "a boolean" if isinstance(value, (bool, np.bool_)) else type(value).__name__
        raise ConfigError(f"{name}: expected a number, got {value!r} ({what})")


def check_positive(value: float, name: str) -> float:
    """Raise ``ConfigError`` unless ``value`` is a finite number > 0.

    Examples
    --------
    >>> check_positive(2.0, "E")
    2.0
    """
    check_number(value, name)
    v = float(value)
    if not np.isfinite(v) or v <= 0.0:
        raise ConfigError(f"{name}: expected a finite value > 0, got {value!r}")
    return v


def check_in_open_interval(value: float, lo: float, hi: float, name: str) -> float:
    """Raise ``ConfigError`` unless ``lo < value < hi``."""
    check_number(value, name)
    v = float(value)
    if not np.isfinite(v) or not (lo < v < hi):
        raise ConfigError(f"{name}: expected a value in ({lo}, {hi}), got {value!r}")
    return v


def validate_array(value, shape: tuple[int, ...], name: str) -> np.ndarray:
    """Return ``value`` as a finite float64 array of ``shape`` (-1 = any size).

    Examples
    --------
    >>> validate_array([1, 2, 3], (3,), "origin").dtype
    dtype('float64')
    """
    check_number(value, name)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{name}: expected numbers of shape {shape}, got {value!r}") from exc
    if arr.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, arr.shape)):
        raise ConfigError(f"{name}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"{name}: expected finite numbers, got {value!r}")
    return arr


def validate_rotation(value, name: str, tol: float = 1e-6) -> np.ndarray:
    """Return a proper rotation matrix (3, 3); raise if not orthonormal with det +1."""
    R = validate_array(value, (3, 3), name)
    if np.abs(R.T @ R - np.eye(3)).max() > tol or np.linalg.det(R) < 0:
        raise ConfigError(f"{name}: expected a proper rotation matrix (orthonormal, det +1)")
    return R
