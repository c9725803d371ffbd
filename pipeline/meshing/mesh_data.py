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
* ``cell_groups`` maps an element-set name to the indices of the solid's cells it holds
  (rows of its one volume block: Abaqus ELSET, gmsh physical volumes, Nastran property
  ids); links with several materials assign them by these names.
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
    cell_groups: Mapping[str, np.ndarray] = field(default_factory=dict)
    cad: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str = ""

    def __post_init__(self) -> None:
        pts = np.ascontiguousarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"MeshData.points: expected shape (n, 3), got {pts.shape}")
        if self.kind not in ("solid", "beam"):
            raise ValueError(f"MeshData.kind: expected 'solid' or 'beam', got {self.kind!r}")
        object.__setattr__(self, "points", pts)
        for name in ("cells", "boundary", "groups", "cell_groups", "cad"):
            frozen = {k: np.asarray(v) for k, v in getattr(self, name).items()}
            object.__setattr__(self, name, MappingProxyType(frozen))

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])


#: vertex and midside swaps that flip a tet (meshio order: the midside nodes follow)
_TET_FLIP = {4: np.array([0, 2, 1, 3]), 10: np.array([0, 2, 1, 3, 6, 5, 4, 7, 9, 8])}
#: Outward faces of a positively oriented tet (meshio order), as triangle(6) nodes.
_TET_FACES = np.array([[0, 2, 1, 6, 5, 4], [0, 1, 3, 4, 8, 7],
                       [1, 2, 3, 5, 9, 8], [0, 3, 2, 7, 9, 6]])


def orient_tets(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Flip negatively oriented tets (vertex volume < 0) to positive orientation."""
    neg = tet_signed_volumes(points, tets) < 0
    if np.any(neg):
        tets = tets.copy()
        tets[neg] = tets[neg][:, _TET_FLIP[tets.shape[1]]]
    return tets


def tet_signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes (k,) m^3 of the straight tets spanned by the 4 vertices of ``tets``."""
    p0, p1, p2, p3 = (points[tets[:, i]] for i in range(4))
    return np.einsum("ij,ij->i", np.cross(p1 - p0, p2 - p0), p3 - p0) / 6.0


def boundary_faces(tets: np.ndarray) -> np.ndarray:
    """Outward boundary triangles (k, 3) or triangle6 (k, 6) of positively oriented tets.

    A face is on the boundary when exactly one tet has it.
    """
    n_face = 3 if tets.shape[1] == 4 else 6
    faces = tets[:, _TET_FACES[:, :n_face]].reshape(-1, n_face)
    key = np.sort(faces[:, :3], axis=1).astype(np.int64)
    n = int(key.max()) + 1 if key.size else 1
    code = (key[:, 0] * n + key[:, 1]) * n + key[:, 2]  # exact for n < 2e6 nodes
    _, inverse, counts = np.unique(code, return_inverse=True, return_counts=True)
    return faces[counts[inverse] == 1]
