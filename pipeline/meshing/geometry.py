"""Descriptions of link geometry: what to mesh, not how (no gmsh here).

Two kinds of link are meshed:

* :class:`SolidGeometry` -- an OCC solid built by a named recipe
  (:data:`pipeline.meshing.recipes.MESH_RECIPES`) or read from a ``.geo`` /
  STEP file, meshed with tetrahedra of order 1 or 2;
* :class:`BeamGeometry` -- a polyline of straight members, meshed with
  2-node line elements.

Both are frozen and validated on construction; recipe parameters are checked
by the recipe itself when the mesh is built (it knows its own fields).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_positive, validate_array
from pipeline.meshing.recipes import MESH_RECIPES


@dataclass(frozen=True)
class SolidGeometry:
    """A solid link to be meshed with tetrahedra.

    Parameters
    ----------
    recipe : str
        Key of :data:`pipeline.meshing.recipes.MESH_RECIPES` (``bar``,
        ``plate_with_bores``, ``bent_plate``, ``box_section``, ``geo``, ``step``).
    params : Mapping[str, Any]
        Recipe parameters, SI units (m); see each recipe's docstring.
    mesh_size : float
        Target element edge length (characteristic length), m.
    order : int
        Geometric and nodal order of the tetrahedra: 1 (tetra) or 2 (tetra10,
        edge nodes placed on the CAD surfaces).
    path : Path, optional
        The ``.geo`` or STEP file of the ``geo`` / ``step`` recipes.

    Examples
    --------
    >>> g = SolidGeometry("bar", {"L": 0.4, "b": 0.008, "h": 0.004}, mesh_size=0.002)
    >>> g.order, g.params["L"]
    (2, 0.4)
    """

    recipe: str
    params: Mapping[str, Any]
    mesh_size: float
    order: int = 2
    path: Path | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.recipe, str) or self.recipe not in MESH_RECIPES:
            raise ConfigError(f"geometry.recipe: expected one of {sorted(MESH_RECIPES)}, "
                              f"got {self.recipe!r}")
        if not isinstance(self.params, Mapping):
            raise ConfigError(f"geometry.params: expected a mapping of recipe parameters, "
                              f"got {type(self.params).__name__}")
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))
        object.__setattr__(self, "mesh_size", check_positive(self.mesh_size, "geometry.mesh_size"))
        if isinstance(self.order, bool) or self.order not in (1, 2):
            raise ConfigError(f"geometry.order: expected 1 or 2, got {self.order!r}")
        if self.path is not None:
            object.__setattr__(self, "path", Path(self.path))
        if self.recipe in ("geo", "step") and self.path is None:
            raise ConfigError(f"geometry.path: the {self.recipe!r} recipe needs a file path")


@dataclass(frozen=True)
class BeamGeometry:
    """A slender link given as a polyline of straight members (beam axis).

    Parameters
    ----------
    points : (k, 3) array_like
        Polyline vertices in the link frame, m; k >= 2, consecutive vertices
        distinct. Member i runs from vertex i to vertex i + 1.
    element_size : float
        Target beam element length, m.
    vertex_names : tuple of str
        Empty, or one unique name per vertex; each named vertex becomes a node
        group of the mesh (``member_<i>`` is reserved for the member groups).

    Examples
    --------
    >>> b = BeamGeometry([[0, 0, 0], [8, 0, 0], [16, 0, 0]], 1.0, ("pivot", "mid", "tip"))
    >>> b.points.shape
    (3, 3)
    """

    points: np.ndarray
    element_size: float
    vertex_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        pts = validate_array(self.points, (-1, 3), "geometry.points")
        if pts.shape[0] < 2:
            raise ConfigError(f"geometry.points: expected at least 2 vertices, got {pts.shape[0]}")
        lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        scale = max(float(np.abs(pts).max()), float(lengths.max()))
        short = np.flatnonzero(lengths <= 1e-12 * scale)
        if short.size:
            i = int(short[0])
            raise ConfigError(f"geometry.points: member {i} has zero length "
                              f"(vertices {i} and {i + 1} coincide)")
        pts.setflags(write=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "element_size",
                           check_positive(self.element_size, "geometry.element_size"))
        names = tuple(self.vertex_names)
        if names and len(names) != pts.shape[0]:
            raise ConfigError(f"geometry.vertex_names: expected {pts.shape[0]} names "
                              f"(one per vertex) or none, got {len(names)}")
        bad = [n for n in names if not isinstance(n, str) or not n]
        if bad:
            raise ConfigError(f"geometry.vertex_names: expected non-empty strings, got {bad!r}")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f"geometry.vertex_names: duplicate names {dup}")
        reserved = [n for n in names if n.startswith("member_")]
        if reserved:
            raise ConfigError(f"geometry.vertex_names: {reserved[0]!r}: names 'member_<i>' are "
                              "reserved for the member node groups")
        object.__setattr__(self, "vertex_names", names)

    @property
    def n_members(self) -> int:
        """Number of straight members (polyline segments)."""
        return int(self.points.shape[0] - 1)
