"""Tabulated drivers: interpolated (time, value) tables, from lists or CSV files."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from scipy.interpolate import CubicSpline, PchipInterpolator

from pipeline.core.errors import ConfigError
from pipeline.core.input_files import MAX_TABLE_BYTES, input_file
from pipeline.kinematics.driver_base import Driver, check_keys, finite_float, out

__all__ = ["Table", "load_table_csv"]


# --------------------------------------------------------------------------- tables
_INTERPOLATIONS = ("linear", "pchip", "spline")


@dataclass(frozen=True, eq=False)
class Table(Driver):
    """Interpolated table of (time, value) points; end values held outside it.

    ``interpolation``:

    - ``"linear"``: piecewise linear (``np.interp``); rate piecewise constant
      (right-hand slope at a knot), acceleration 0.
    - ``"pchip"``: scipy ``PchipInterpolator``, monotone and C1. It never
      overshoots the data, so a stroke table stays inside the cylinder's
      limits; its acceleration jumps at the knots.
    - ``"spline"``: scipy ``CubicSpline`` with ``bc_type="clamped"`` (zero
      slope at both ends), C2 inside and C1 across the ends into the held
      values; use it when accelerations drive dynamics. It may overshoot
      between knots of non-smooth data.

    For t < times[0] or t > times[-1] the value is the end value and rate and
    acceleration are 0.
    """

    times: np.ndarray
    values: np.ndarray
    interpolation: str = "linear"
    _interp: Any = field(default=None, init=False, repr=False, compare=False)
    type_name: ClassVar[str] = "table"

    def __post_init__(self):
        t = _table_axis(self.times, self.values, "table")
        v = np.array(self.values, dtype=float)
        t.flags.writeable = False
        v.flags.writeable = False
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)
        if self.interpolation not in _INTERPOLATIONS:
            raise ConfigError(f"table.interpolation: expected one of {_INTERPOLATIONS}, "
                              f"got {self.interpolation!r}")
        interp = None
        if self.interpolation == "pchip":
            interp = PchipInterpolator(t, v)
        elif self.interpolation == "spline":
            interp = CubicSpline(t, v, bc_type="clamped")
        object.__setattr__(self, "_interp", interp)

    def _eval(self, t, k: int):
        tt = np.asarray(t, dtype=float)
        t0, t1 = self.times[0], self.times[-1]
        if k == 0:
            if self._interp is None:
                return out(t, np.interp(tt, self.times, self.values))
            return out(t, np.where(tt <= t0, self.values[0], np.where(
                tt >= t1, self.values[-1], self._interp(np.clip(tt, t0, t1)))))
        inside = (tt >= t0) & (tt < t1)
        if self._interp is None:
            if k == 2:
                return out(t, 0.0)
            slopes = np.diff(self.values) / np.diff(self.times)
            i = np.clip(np.searchsorted(self.times, tt, side="right") - 1, 0, len(slopes) - 1)
            return out(t, np.where(inside, slopes[i], 0.0))
        return out(t, np.where(inside, self._interp(np.clip(tt, t0, t1), k), 0.0))

    def value(self, t):
        return self._eval(t, 0)

    def rate(self, t):
        return self._eval(t, 1)

    def accel(self, t):
        return self._eval(t, 2)

    def breaks(self) -> tuple[float, ...]:
        # linear: the rate jumps at every knot; pchip: the acceleration does (and the rate
        # at the ends); the clamped spline is C2 inside, its acceleration jumps at the ends
        t = self.times if self.interpolation != "spline" else self.times[[0, -1]]
        return tuple(float(x) for x in t)

    @classmethod
    def from_dict(cls, d: dict, where: str, base_dir: Path | None = None) -> Table:
        """Build from ``{"times": [...], "values": [...]}`` or ``{"file": "x.csv"}``.

        A relative ``file`` is resolved against ``base_dir`` (the workflow's
        folder) when given, else against the working directory.
        """
        check_keys(d, {"times", "values", "file", "interpolation"}, where)
        interp = d.get("interpolation", "linear")
        if interp not in _INTERPOLATIONS:
            raise ConfigError(f"{where}.interpolation: expected one of {_INTERPOLATIONS}, "
                              f"got {interp!r}")
        if "file" in d:
            if "times" in d or "values" in d:
                raise ConfigError(f"{where}: give either 'file' or 'times'/'values', not both")
            path = Path(d["file"])
            if base_dir is not None and not path.is_absolute():
                path = Path(base_dir) / path
            try:
                input_file(path, "table file", MAX_TABLE_BYTES)
            except ConfigError as exc:
                raise ConfigError(f"{where}.file: {exc}") from None
            t, v = load_table_csv(path)
            return cls(t, v, interp)
        for key in ("times", "values"):
            if key not in d:
                raise ConfigError(f"{where}.{key}: required field is missing (or give 'file')")
        t = _number_list(d["times"], f"{where}.times")
        v = _number_list(d["values"], f"{where}.values")
        _table_axis(t, v, where)
        return cls(t, v, interp)


def _number_list(raw, where: str) -> np.ndarray:
    if isinstance(raw, (str, bytes, dict)) or not hasattr(raw, "__len__"):
        raise ConfigError(f"{where}: expected a list of numbers, got {raw!r}")
    return np.array([finite_float(x, f"{where}[{i}]") for i, x in enumerate(raw)], dtype=float)


def _table_axis(times, values, where: str) -> np.ndarray:
    """Check a table's axes; return the times as a float array."""
    t = np.array(times, dtype=float)
    v = np.asarray(values, dtype=float)
    if t.ndim != 1 or v.shape != t.shape:
        raise ConfigError(f"{where}: expected times and values of equal length, "
                          f"got shapes {t.shape} and {v.shape}")
    if t.size < 2:
        raise ConfigError(f"{where}: expected at least 2 points, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise ConfigError(f"{where}: expected finite times and values")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise ConfigError(f"{where}.times[{i}]: expected strictly increasing times, "
                          f"got {t[i]} after {t[i - 1]}")
    return t


def load_table_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a two-column CSV table (time in s, value in SI units).

    One optional header row (non-numeric first row) is skipped, as are blank
    lines and lines starting with ``#``.

    Returns
    -------
    times, values : ndarray (n,)
        Strictly increasing times and their values, n >= 2.

    Raises
    ------
    ConfigError
        Unreadable file; a row without exactly two cells; a non-numeric cell
        (naming file, line and column); non-increasing time; fewer than 2 rows.
    """
    path = input_file(path, "table file", MAX_TABLE_BYTES)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read table file ({exc.strerror})") from None
    rows: list[tuple[float, float, int]] = []
    first = True
    for lineno, cells in _csv_rows(text):
        if len(cells) != 2:
            raise ConfigError(f"{path}, line {lineno}: expected 2 columns (time, value), "
                              f"got {len(cells)}")
        parsed = [_csv_float(c) for c in cells]
        if first and all(p is None for p in parsed):
            first = False  # header row
            continue
        first = False
        for name, cell, p in zip(("time", "value"), cells, parsed):
            if p is None:
                raise ConfigError(f"{path}, line {lineno}, column '{name}': "
                                  f"expected a finite number, got {cell!r}")
        if rows and parsed[0] <= rows[-1][0]:
            raise ConfigError(f"{path}, line {lineno}: time {parsed[0]} is not greater than "
                              f"the previous time {rows[-1][0]} (line {rows[-1][2]})")
        rows.append((parsed[0], parsed[1], lineno))
    if len(rows) < 2:
        raise ConfigError(f"{path}: expected at least 2 data rows (time, value), got {len(rows)}")
    arr = np.array([(a, b) for a, b, _ in rows], dtype=float)
    return arr[:, 0], arr[:, 1]


def _csv_rows(text: str):
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        yield lineno, [c.strip() for c in next(csv.reader([line]))]


def _csv_float(cell: str) -> float | None:
    try:
        v = float(cell)  # float() parses numbers only; user text is never evaluated
    except ValueError:
        return None
    return v if math.isfinite(v) else None
