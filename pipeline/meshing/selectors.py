"""Geometric node selectors for interfaces (pure numpy, no gmsh).

Every selector is a frozen dataclass with
``select(points, candidates, groups) -> ndarray[int]``: the sorted ids among
``candidates`` (typically the boundary nodes of the FE mesh) that it matches.
A selector matching nothing raises :class:`ConfigError` saying what it looked
for. :data:`SELECTORS` maps the workflow ``selector.type`` to the class; its
fields are the YAML fields.

Examples
--------
>>> import numpy as np
>>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
>>> PlaneFace(point=(1, 0, 0), normal=(1, 0, 0)).select(pts, np.arange(3), {})
array([1, 2])
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_positive, validate_array


def _vec3(value, name: str, unit: bool = False) -> tuple[float, float, float]:
    v = validate_array(value, (3,), name)
    if unit:
        n = float(np.linalg.norm(v))
        if n == 0.0:
            raise ConfigError(f"{name}: expected a non-zero direction, got {value!r}")
        v = v / n
    return (float(v[0]), float(v[1]), float(v[2]))


def _inputs(points, candidates) -> tuple[np.ndarray, np.ndarray]:
    pts = validate_array(points, (-1, 3), "selector points")
    ids = np.asarray(candidates)
    if ids.ndim != 1 or (ids.size and not np.issubdtype(ids.dtype, np.integer)):
        raise ConfigError(f"selector candidates: expected a 1-D integer array, got {ids.dtype} "
                          f"of shape {ids.shape}")
    ids = np.unique(ids.astype(np.int64))
    if ids.size and (ids[0] < 0 or ids[-1] >= pts.shape[0]):
        raise ConfigError(f"selector candidates: expected ids in [0, {pts.shape[0]}), "
                          f"got {ids[0]}..{ids[-1]}")
    return pts, ids


def _matched(selector, ids: np.ndarray) -> np.ndarray:
    if ids.size == 0:
        raise ConfigError(f"{selector!r} matched no boundary nodes")
    return ids


@dataclass(frozen=True)
class PhysicalGroup:
    """Nodes of a named physical group of the mesh (``MeshData.groups``)."""

    name: str

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"PhysicalGroup.name: expected a non-empty string, got {self.name!r}")

    def select(self, points, candidates, groups: Mapping[str, np.ndarray]) -> np.ndarray:
        _, ids = _inputs(points, candidates)
        if self.name not in groups:
            raise ConfigError(f"PhysicalGroup: unknown group {self.name!r}; available groups: "
                              f"{sorted(groups) or 'none'}")
        return _matched(self, np.intersect1d(ids, np.asarray(groups[self.name], np.int64)))


@dataclass(frozen=True)
class CylinderSurface:
    """Nodes at distance ``radius`` +- ``tol`` from the axis line (a bore surface).

    ``point`` (3,) m lies on the axis, ``axis`` (3,) is its direction (any
    length), ``radius`` m; ``tol`` m defaults to 1e-3 * radius (the FE nodes of
    a bore lie on the CAD cylinder; neighbouring nodes are a mesh size away).
    """

    point: tuple[float, float, float]
    axis: tuple[float, float, float]
    radius: float
    tol: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vec3(self.point, "CylinderSurface.point"))
        object.__setattr__(self, "axis", _vec3(self.axis, "CylinderSurface.axis", unit=True))
        object.__setattr__(self, "radius", check_positive(self.radius, "CylinderSurface.radius"))
        if self.tol is not None:
            object.__setattr__(self, "tol", check_positive(self.tol, "CylinderSurface.tol"))

    def select(self, points, candidates, groups=None) -> np.ndarray:
        pts, ids = _inputs(points, candidates)
        rel = pts[ids] - np.asarray(self.point)
        radial = rel - np.outer(rel @ np.asarray(self.axis), self.axis)
        tol = self.tol if self.tol is not None else 1e-3 * self.radius
        return _matched(self, ids[np.abs(np.linalg.norm(radial, axis=1) - self.radius) <= tol])


@dataclass(frozen=True)
class PlaneFace:
    """Nodes within ``tol`` of the plane through ``point`` with ``normal``.

    ``tol`` m defaults to 1e-6 times the diagonal of the points' bounding box.
    """

    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    tol: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vec3(self.point, "PlaneFace.point"))
        object.__setattr__(self, "normal", _vec3(self.normal, "PlaneFace.normal", unit=True))
        if self.tol is not None:
            object.__setattr__(self, "tol", check_positive(self.tol, "PlaneFace.tol"))

    def select(self, points, candidates, groups=None) -> np.ndarray:
        pts, ids = _inputs(points, candidates)
        tol = self.tol
        if tol is None:
            tol = 1e-6 * float(np.linalg.norm(np.ptp(pts, axis=0))) if pts.size else 0.0
        dist = (pts[ids] - np.asarray(self.point)) @ np.asarray(self.normal)
        return _matched(self, ids[np.abs(dist) <= tol])


@dataclass(frozen=True)
class NearestNode:
    """The single candidate node nearest to ``point`` (3,) m (lowest id on ties)."""

    point: tuple[float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vec3(self.point, "NearestNode.point"))

    def select(self, points, candidates, groups=None) -> np.ndarray:
        pts, ids = _inputs(points, candidates)
        if ids.size == 0:
            return _matched(self, ids)
        d = np.linalg.norm(pts[ids] - np.asarray(self.point), axis=1)
        return ids[[int(np.argmin(d))]]


@dataclass(frozen=True)
class BoxRegion:
    """Nodes with lo <= x <= hi componentwise (an axis-aligned box, m)."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "lo", _vec3(self.lo, "BoxRegion.lo"))
        object.__setattr__(self, "hi", _vec3(self.hi, "BoxRegion.hi"))
        if any(a > b for a, b in zip(self.lo, self.hi)):
            raise ConfigError(f"BoxRegion: expected lo <= hi componentwise, got lo={self.lo}, "
                              f"hi={self.hi}")

    def select(self, points, candidates, groups=None) -> np.ndarray:
        pts, ids = _inputs(points, candidates)
        p = pts[ids]
        inside = np.all((p >= np.asarray(self.lo)) & (p <= np.asarray(self.hi)), axis=1)
        return _matched(self, ids[inside])


Selector = PhysicalGroup | CylinderSurface | PlaneFace | NearestNode | BoxRegion

#: workflow ``selector.type`` -> selector class (fields = the YAML fields).
SELECTORS: dict[str, type] = {
    "group": PhysicalGroup,
    "cylinder": CylinderSurface,
    "plane": PlaneFace,
    "nearest": NearestNode,
    "box": BoxRegion,
}
