"""Parameters of the solid recipes: parsing and validation (no gmsh here).

Each recipe in :mod:`pipeline.meshing.recipes` reads its ``params`` through
these functions, so a bad field is reported with the link's YAML path
(``where``), the field and what was expected before any geometry is built.
The parsed records (:class:`Bore`, :class:`CrossBore`, :class:`BentPlate`,
:class:`Lug`) are frozen; lengths are metres in the link frame.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_positive, validate_array


@dataclass(frozen=True)
class Bore:
    """Through bore along z of a flat plate: centre (x, y) m, radius m."""

    name: str
    center: tuple[float, float]
    radius: float


@dataclass(frozen=True)
class CrossBore:
    """Bore through both walls of a box section, along ``axis`` ('y' or 'z').

    ``x`` is the station along the tube, ``offset`` the shift along the other
    transverse axis, m.
    """

    name: str
    x: float
    radius: float
    axis: str
    offset: float = 0.0


@dataclass(frozen=True)
class BentPlate:
    """Validated parameters of the ``bent_plate`` recipe (see its docstring)."""

    points: np.ndarray  # (k, 2) m
    point_names: tuple[str, ...]
    width: float
    knee_width: float
    thickness: float
    rounded_ends: bool
    bores: tuple[Bore, ...]
    lugs: tuple[Lug, ...] = ()


@dataclass(frozen=True)
class Lug:
    """A tab of a bent plate carrying a pin off the members' centre lines: a strip of
    ``width`` from ``root`` (inside the plate) to ``center``, with a half-round end there
    (m)."""

    name: str
    root: tuple[float, float]
    center: tuple[float, float]
    width: float


def check_keys(params: Mapping[str, Any], where: str, required: tuple[str, ...] = (),
               optional: tuple[str, ...] = (), path: str = "params") -> None:
    """Raise ConfigError on a missing required or an unknown parameter at ``path``."""
    allowed = set(required) | set(optional)
    unknown = sorted(set(params) - allowed)
    if unknown:
        raise ConfigError(f"{where}: {path}.{unknown[0]}: unknown parameter; "
                          f"expected {sorted(allowed) or 'no parameters'}")
    missing = [k for k in required if k not in params]
    if missing:
        raise ConfigError(f"{where}: {path}.{missing[0]}: missing; required {list(required)}")


def positive(params: Mapping[str, Any], key: str, where: str, path: str = "params") -> float:
    """``params[key]`` as a finite float > 0, else ConfigError naming ``path.key``."""
    try:
        return check_positive(params[key], f"{where}: {path}.{key}")
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"{where}: {path}.{key}: expected a finite value > 0, "
                          f"got {params[key]!r}") from None


def _entries(value: Any, field_name: str, where: str) -> list[Mapping[str, Any]]:
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, Mapping) for v in value):
        raise ConfigError(f"{where}: params.{field_name}: expected a list of mappings, "
                          f"got {value!r}")
    return list(value)


def _name(entry: Mapping[str, Any], field_name: str, where: str) -> str:
    name = entry.get("name", entry.get("at"))
    if not isinstance(name, str) or not name.replace("_", "").replace("-", "").isalnum():
        raise ConfigError(f"{where}: params.{field_name}.name: expected an identifier "
                          f"(letters, digits, _ or -), got {name!r}")
    return name


def _unique(names: list[str], field_name: str, where: str) -> None:
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"{where}: params.{field_name}: duplicate names {dup}")


def parse_plate_bores(value: Any, where: str, points: Mapping[str, np.ndarray] | None = None
                      ) -> tuple[Bore, ...]:
    """Bores given as ``{name, center: [x, y], radius}`` or ``{name, at, radius}``."""
    bores = []
    for i, e in enumerate(_entries(value, "bores", where)):
        fld = f"bores[{i}]"
        check_keys(e, where, required=("radius",), optional=("name", "center", "at"),
                   path=f"params.{fld}")
        name = _name(e, fld, where)
        radius = positive(e, "radius", where, f"params.{fld}")
        if "at" in e and points is not None:
            if e["at"] not in points:
                raise ConfigError(f"{where}: params.{fld}.at: unknown point {e['at']!r}; "
                                  f"points: {sorted(points)}")
            c = points[e["at"]]
        elif "center" in e:
            c = validate_array(e["center"], (2,), f"{where}: params.{fld}.center")
        else:
            need = "'center' or 'at'" if points is not None else "'center'"
            raise ConfigError(f"{where}: params.{fld}: expected {need}")
        bores.append(Bore(name, (float(c[0]), float(c[1])), radius))
    _unique([b.name for b in bores], "bores", where)
    _check_disjoint(bores, where)
    return tuple(bores)


def _check_disjoint(bores, where: str) -> None:
    for i, a in enumerate(bores):
        for b in bores[i + 1:]:
            if np.hypot(a.center[0] - b.center[0], a.center[1] - b.center[1]) \
                    <= a.radius + b.radius:
                raise ConfigError(f"{where}: params.bores: bores {a.name!r} and {b.name!r} "
                                  "overlap; expected disjoint bores")


def _sd_box(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Signed distance of a 2D point to an axis-aligned box (negative inside)."""
    q = np.abs(p - (lo + hi) / 2) - (hi - lo) / 2
    return float(np.linalg.norm(np.maximum(q, 0.0)) + min(max(q[0], q[1]), 0.0))


def check_plate_bores(bores: tuple[Bore, ...], length: float, width: float, rc: float,
                      where: str) -> None:
    """Every bore strictly inside the (rounded) rectangle [0, length] x [-w/2, w/2]."""
    lo, hi = np.array([rc, -width / 2 + rc]), np.array([length - rc, width / 2 - rc])
    for b in bores:
        if _sd_box(np.array(b.center), lo, hi) - rc + b.radius >= 0.0:
            raise ConfigError(f"{where}: params.bores: bore {b.name!r} (center {b.center}, "
                              f"radius {b.radius}) is not inside the plate outline")


def parse_bent_plate(params: Mapping[str, Any], where: str) -> BentPlate:
    """Validate the ``bent_plate`` parameters (see the recipe's docstring)."""
    check_keys(params, where, required=("points", "width", "thickness"),
               optional=("point_names", "knee_width", "rounded_ends", "bores", "lugs"))
    pts = validate_array(params["points"], (-1, 2), f"{where}: params.points")
    if pts.shape[0] < 2:
        raise ConfigError(f"{where}: params.points: expected at least 2 points "
                          f"(pivot, [knees,] tip), got {pts.shape[0]}")
    width, t = positive(params, "width", where), positive(params, "thickness", where)
    if np.any(np.linalg.norm(np.diff(pts, axis=0), axis=1) <= width / 2):
        raise ConfigError(f"{where}: params.points: expected members longer than width/2")
    names = tuple(params.get("point_names") or (f"p{i}" for i in range(len(pts))))
    if len(names) != len(pts):
        raise ConfigError(f"{where}: params.point_names: expected {len(pts)} names, "
                          f"got {len(names)}")
    _unique(list(names), "point_names", where)
    knee = positive(params, "knee_width", where) if "knee_width" in params else width
    if knee < width:
        raise ConfigError(f"{where}: params.knee_width: expected >= width ({width}), got {knee}")
    plate = BentPlate(pts, names, width, knee, t, bool(params.get("rounded_ends", True)), ())
    lugs = _parse_lugs(params.get("lugs", []) or [], plate, where)
    clash = sorted(set(names) & {g.name for g in lugs})
    if clash:
        raise ConfigError(f"{where}: params.lugs: names {clash} are point names too")
    points = dict(zip(names, pts)) | {g.name: np.array(g.center) for g in lugs}
    arm = replace(plate, lugs=lugs,
                  bores=parse_plate_bores(params.get("bores", []) or [], where, points))
    for b in arm.bores:
        if not _bore_in_arm(arm, np.array(b.center), b.radius):
            raise ConfigError(f"{where}: params.bores: bore {b.name!r} (center {b.center}, "
                              f"radius {b.radius}) is not inside the plate outline")
    return arm


def _parse_lugs(value: Any, plate: BentPlate, where: str) -> tuple[Lug, ...]:
    """Lugs ``{name, root: [x, y] | <point name>, center: [x, y], width}``: the root strictly
    inside the members' outline, the lug longer than its half width."""
    points = dict(zip(plate.point_names, plate.points))
    lugs = []
    for i, e in enumerate(_entries(value, "lugs", where)):
        fld = f"params.lugs[{i}]"
        check_keys(e, where, required=("name", "root", "center", "width"), path=fld)
        name = _name(e, f"lugs[{i}]", where)
        width = positive(e, "width", where, fld)
        if isinstance(e["root"], str):
            if e["root"] not in points:
                raise ConfigError(f"{where}: {fld}.root: unknown point {e['root']!r}; "
                                  f"points: {sorted(points)}")
            root = points[e["root"]]
        else:
            root = validate_array(e["root"], (2,), f"{where}: {fld}.root")
        center = validate_array(e["center"], (2,), f"{where}: {fld}.center")
        if not _bore_in_arm(plate, root, 0.0):
            raise ConfigError(f"{where}: {fld}.root: expected a point inside the plate "
                              f"outline, got {list(map(float, root))}")
        if np.linalg.norm(center - root) <= width / 2:
            raise ConfigError(f"{where}: {fld}: expected the centre more than width/2 "
                              f"({width / 2}) from the root")
        lugs.append(Lug(name, (float(root[0]), float(root[1])),
                        (float(center[0]), float(center[1])), width))
    _unique([g.name for g in lugs], "lugs", where)
    return tuple(lugs)


def _bore_in_arm(arm: BentPlate, c: np.ndarray, r: float) -> bool:
    """Is the disc (c, r) inside one piece (strip or end/knee disc, lug strip or end) of
    the outline?"""
    for g in arm.lugs:
        p, q = np.array(g.root), np.array(g.center)
        if np.linalg.norm(c - q) + r < g.width / 2 or _in_strip(c, r, p, q, g.width):
            return True
    k = len(arm.points)
    for i, p in enumerate(arm.points):
        end = i in (0, k - 1)
        radius = arm.width / 2 if end else arm.knee_width / 2
        if (not end or arm.rounded_ends) and np.linalg.norm(c - p) + r < radius:
            return True
    return any(_in_strip(c, r, p, q, arm.width)
               for p, q in zip(arm.points[:-1], arm.points[1:]))


def _in_strip(c: np.ndarray, r: float, p: np.ndarray, q: np.ndarray, width: float) -> bool:
    """Is the disc (c, r) strictly inside the strip of ``width`` from p to q?"""
    d = (q - p) / np.linalg.norm(q - p)
    local = np.array([(c - p) @ d, d[0] * (c - p)[1] - d[1] * (c - p)[0]])
    lo, hi = np.array([0.0, -width / 2]), np.array([np.linalg.norm(q - p), width / 2])
    return _sd_box(local, lo, hi) + r < 0.0


def parse_box_bores(value: Any, L: float, b: float, h: float, wall: float, tp: float,
                    where: str) -> tuple[CrossBore, ...]:
    """Cross bores of ``box_section``: each strictly inside the flat part of its walls."""
    bores = []
    for i, e in enumerate(_entries(value, "cross_bores", where)):
        fld = f"cross_bores[{i}]"
        check_keys(e, where, required=("name", "x", "radius", "axis"), optional=("offset",),
                   path=f"params.{fld}")
        r = positive(e, "radius", where, f"params.{fld}")
        if e["axis"] not in ("y", "z"):
            raise ConfigError(f"{where}: params.{fld}.axis: expected 'y' or 'z', "
                              f"got {e['axis']!r}")
        x = float(validate_array(e["x"], (), f"{where}: params.{fld}.x"))
        off = float(validate_array(e.get("offset", 0.0), (), f"{where}: params.{fld}.offset"))
        half = (h if e["axis"] == "y" else b) / 2 - wall  # flat part of the pierced wall
        if not (x - r > tp and x + r < L - tp and abs(off) + r < half):
            raise ConfigError(f"{where}: params.{fld}: bore (x={x}, offset={off}, radius={r}) "
                              "must lie inside the flat part of the walls")
        bores.append(CrossBore(_name(e, fld, where), x, r, e["axis"], off))
    _unique([c.name for c in bores], "cross_bores", where)
    for i, a in enumerate(bores):
        for c in bores[i + 1:]:
            if a.axis == c.axis and np.hypot(a.x - c.x, a.offset - c.offset) <= a.radius + c.radius:
                raise ConfigError(f"{where}: params.cross_bores: bores {a.name!r} and "
                                  f"{c.name!r} overlap; expected disjoint bores")
    return tuple(bores)
