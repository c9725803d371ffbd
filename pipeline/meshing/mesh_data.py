"""The mesh artifact handed from meshing to the FE stage.

Contract (shared by ``pipeline.meshing`` which produces it and
``pipeline.fem`` which consumes it):

* ``points`` are (n, 3) float64 coordinates in metres, in the link frame the
  geometry was described in.
* ``cells`` maps a meshio cell-type name to its (k, nodes_per_cell) int64
  connectivity into ``points``: ``"tetra10"`` (gmsh/meshio node order) or
  ``"tetra"`` for solids, ``"line"`` for beams.
* ``boundary`` is the surface triangulation of a solid (``"triangle6"`` or
  ``"triangle"``), used for interface selection and rendering; empty for beams.
* ``groups`` maps a physical-group name to the node indices it contains.
* ``cad`` holds the exact mass properties of the CAD solid per unit density
  (``volume`` m^3, ``centroid`` (3,) m, ``second_moment`` (3, 3) m^5 =
  integral of x x^T dV) when the geometry came from OCC; empty otherwise.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np


@dataclass(frozen=True)
class MeshData:
    """Undeformed mesh of one link (SI units, link frame)."""

    points: np.ndarray
    cells: Mapping[str, np.ndarray]
    kind: str  # "solid" or "beam"
    order: int = 1
    boundary: Mapping[str, np.ndarray] = field(default_factory=dict)
    groups: Mapping[str, np.ndarray] = field(default_factory=dict)
    cad: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str = ""

    def __post_init__(self) -> None:
        pts = np.ascontiguousarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"MeshData.points: expected shape (n, 3), got {pts.shape}")
        if self.kind not in ("solid", "beam"):
            raise ValueError(f"MeshData.kind: expected 'solid' or 'beam', got {self.kind!r}")
        object.__setattr__(self, "points", pts)
        for name in ("cells", "boundary", "groups", "cad"):
            frozen = {k: np.asarray(v) for k, v in getattr(self, name).items()}
            object.__setattr__(self, name, MappingProxyType(frozen))

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])
