"""Meshes made by other FE tools, read with meshio: Abaqus ``.inp``, Nastran ``.bdf`` /
``.nas``, gmsh ``.msh``, VTK ``.vtu`` / ``.vtk`` and XDMF ``.xdmf``.

An engineer with a validated FE model of a boom brings its mesh as it is: its linear or
quadratic tetrahedra (C3D4 / C3D10, CTETRA, tetra / tetra10) become the link's solid, its
node sets and element sets (Abaqus NSET / ELSET, gmsh physical groups, meshio point and
cell sets) become named node groups for the interface and marker selectors
(``{type: group, name: ...}``), and its element sets (cell sets, gmsh physical volumes,
Nastran property ids as ``PID<n>``) named cell groups for a link of several materials.
Coordinates are scaled from the file's ``units`` to metres.

What the import cannot check by itself it says: a mesh in millimetres read as metres is a
link a thousand times too large, which :func:`check_units` catches against the positions
the spec gives in metres (interfaces, markers) and an optional expected mass. Hexahedra,
wedges and pyramids are refused with the remedy (the FE stage takes tetrahedra); shells
and beams in the file are left out of the solid, and said so.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.core.errors import ConfigError, MeshError
from pipeline.meshing.mesh_data import MeshData, boundary_faces, orient_tets, tet_signed_volumes

logger = logging.getLogger(__name__)

__all__ = ["MASS_UNITS", "MATRIX_FORMATS", "MESH_FORMATS", "UNITS", "MatrixFiles",
           "MeshFileGeometry", "check_units", "read_mesh"]

#: file suffix -> meshio format name
MESH_FORMATS = {".inp": "abaqus", ".bdf": "nastran", ".nas": "nastran", ".fem": "nastran",
                ".msh": "gmsh", ".vtu": "vtu", ".vtk": "vtk", ".xdmf": "xdmf"}
#: length unit -> metres
UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254, "ft": 0.3048}
#: mass unit -> kg (of a consistent set with the length unit and seconds)
MASS_UNITS = {"kg": 1.0, "t": 1000.0, "g": 1e-3}
#: the matrix files :mod:`pipeline.fem.imported` reads
MATRIX_FORMATS = ("calculix", "abaqus")
#: volume cells the FE stage takes, and those it does not (with what to do instead)
_TETS = ("tetra10", "tetra")
_OTHER_VOLUMES = ("hexahedron", "hexahedron20", "hexahedron27", "wedge", "wedge15",
                  "wedge18", "pyramid", "pyramid13", "pyramid14")
#: the largest file read, bytes (a 2 GB text mesh is ~20 M nodes, beyond a link)
MAX_MESH_BYTES = 2 * 2**30


@dataclass(frozen=True)
class MatrixFiles:
    """Where a link's K and M come from.

    format : ``calculix`` or ``abaqus``; stiffness, mass : the matrix files; dofs : the
    CalculiX ``.dof`` file (None for abaqus); nodes_from : the FE code's input file whose
    ``*NODE`` lines number the nodes; mass_unit : a key of :data:`MASS_UNITS`.
    """

    format: str
    stiffness: Path
    mass: Path
    nodes_from: Path
    dofs: Path | None = None
    mass_unit: str = "kg"

    def __post_init__(self) -> None:
        if self.format not in MATRIX_FORMATS:
            raise ConfigError(f"geometry.matrices.format: expected one of {MATRIX_FORMATS}, "
                              f"got {self.format!r}")
        if self.mass_unit not in MASS_UNITS:
            raise ConfigError(f"geometry.matrices.mass_unit: expected one of "
                              f"{sorted(MASS_UNITS)}, got {self.mass_unit!r}")
        for name in ("stiffness", "mass", "nodes_from", "dofs"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, Path(getattr(self, name)))
        if self.format == "calculix" and self.dofs is None:
            raise ConfigError("geometry.matrices.dofs: CalculiX matrices need their .dof file")

    def files(self) -> tuple[Path, ...]:
        return tuple(p for p in (self.stiffness, self.mass, self.dofs, self.nodes_from)
                     if p is not None)


@dataclass(frozen=True)
class MeshFileGeometry:
    """A solid link whose mesh comes from a file.

    Parameters
    ----------
    path : Path
        The mesh file (a suffix of :data:`MESH_FORMATS`).
    units : str
        Length unit of the file's coordinates (a key of :data:`UNITS`).
    expected_mass : float, optional
        The link's mass as the FE tool reports it, kg (checked by :func:`check_units`).
    matrices : MatrixFiles, optional
        The FE tool's own K and M of this mesh, used instead of assembling them here
        (:mod:`pipeline.fem.imported`).

    Examples
    --------
    >>> g = MeshFileGeometry("boom.inp", "mm")
    >>> g.scale, g.format
    (0.001, 'abaqus')
    """

    path: Path
    units: str = "m"
    expected_mass: float | None = None
    matrices: MatrixFiles | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))
        if self.path.suffix.lower() not in MESH_FORMATS:
            raise ConfigError(f"geometry.path: {self.path.name}: expected a mesh file with "
                              f"one of the suffixes {sorted(MESH_FORMATS)}")
        if self.units not in UNITS:
            raise ConfigError(f"geometry.units: expected one of {sorted(UNITS)}, "
                              f"got {self.units!r}")

    def files(self) -> tuple[Path, ...]:
        """Every file the link is read from: the mesh, then the matrices' own files."""
        if self.matrices is None:
            return (self.path,)
        return (self.path,) + tuple(p for p in self.matrices.files() if p != self.path)

    @property
    def scale(self) -> float:
        """Metres per file unit."""
        return UNITS[self.units]

    @property
    def format(self) -> str:
        """meshio's name of the file's format."""
        return MESH_FORMATS[self.path.suffix.lower()]


def read_mesh(geometry: MeshFileGeometry, name: str) -> MeshData:
    """The solid mesh of ``geometry``'s file as a :class:`MeshData` (metres, outward
    boundary, node groups by set name).

    Raises
    ------
    MeshError
        File missing, unreadable or too large; no tetrahedra; tetrahedra of both orders;
        volume cells other than tetrahedra; degenerate tetrahedra.
    """
    import meshio

    where = f"link {name!r}: geometry.path: {geometry.path}"
    path = geometry.path
    if not path.is_file():
        raise MeshError(f"{where}: no such file")
    if path.stat().st_size > MAX_MESH_BYTES:
        raise MeshError(f"{where}: {path.stat().st_size / 2**30:.1f} GB is more than the "
                        f"{MAX_MESH_BYTES / 2**30:.0f} GB a link's mesh may be")
    try:
        m = meshio.read(path, file_format=geometry.format)
    except (meshio.ReadError, OSError, ValueError, KeyError, IndexError, TypeError, RuntimeError,
            AssertionError, UnicodeDecodeError) as exc:  # meshio's errors on bad files
        raise MeshError(f"{where}: meshio could not read it as {geometry.format}: "
                        f"{type(exc).__name__}: {exc}") from None
    blocks = [(c.type, np.asarray(c.data, dtype=np.int64)) for c in m.cells]
    kinds = {t for t, _ in blocks}
    other = sorted(kinds & set(_OTHER_VOLUMES))
    if other:
        raise MeshError(f"{where}: has {', '.join(other)} cells; the FE stage takes "
                        "tetrahedra (C3D4/C3D10, CTETRA): mesh the part with tetrahedra, or "
                        "split the hexahedra in the FE tool")
    tets = [t for t in _TETS if t in kinds]
    if not tets:
        raise MeshError(f"{where}: has no tetrahedra (cells: {sorted(kinds) or 'none'})")
    if len(tets) > 1:
        raise MeshError(f"{where}: mixes linear and quadratic tetrahedra; use one order")
    cell = tets[0]
    left = sorted(kinds - {cell, "vertex"})
    if left:
        logger.info("%s: %s cells are not part of the solid and are left out", where,
                    ", ".join(left))
    conn = np.concatenate([d for t, d in blocks if t == cell])
    points = np.asarray(m.points, dtype=float)
    if points.shape[1] == 2:
        raise MeshError(f"{where}: its points are 2D; a solid link needs x, y, z")
    points = points[:, :3] * geometry.scale
    # only the solid's nodes: reference nodes, shell or beam nodes would be free nodes
    used = np.unique(conn)
    new = np.full(len(points), -1, dtype=np.int64)
    new[used] = np.arange(used.size)
    conn = new[conn]
    points = points[used]
    vol = tet_signed_volumes(points, conn)
    scale = float(np.ptp(points, axis=0).max()) if points.size else 0.0
    if np.any(np.abs(vol) <= 1e-12 * scale ** 3):
        k = int(np.argmin(np.abs(vol)))
        raise MeshError(f"{where}: tetrahedron {k} is degenerate (volume {vol[k]:.3g} m^3)")
    conn = orient_tets(points, conn)
    groups = _groups(m, blocks, new, where)
    face = "triangle6" if cell == "tetra10" else "triangle"
    return MeshData(points=points, cells={cell: conn}, kind="solid",
                    order=2 if cell == "tetra10" else 1, boundary={face: boundary_faces(conn)},
                    groups=groups, cell_groups=_cell_groups(m, blocks, cell),
                    source=f"import:{geometry.format}:{path}")


def _set_rows(m, dim: int | None = None):
    """(name, block index, rows) of each of the file's cell sets and gmsh physical groups
    (of dimension ``dim`` only, where given), block by block; empty ones left out."""
    for name, per_block in (m.cell_sets or {}).items():
        for b, idx in enumerate(per_block):
            if idx is not None and len(idx):
                yield str(name), b, np.asarray(idx, dtype=np.int64).ravel()
    physical = (m.cell_data or {}).get("gmsh:physical")
    if physical is not None and m.field_data:
        tags = {int(v[0]): n for n, v in m.field_data.items() if dim in (None, int(v[-1]))}
        for b, phys in enumerate(physical):
            for tag in np.unique(phys):
                if int(tag) in tags:
                    yield tags[int(tag)], b, np.flatnonzero(phys == tag)


def _cell_groups(m, blocks, cell: str) -> dict[str, np.ndarray]:
    """Element sets of the solid, by name: the rows of its tetrahedra (the blocks of type
    ``cell`` in file order) that each cell set, gmsh physical volume or Nastran property id
    (``PID<n>``) holds; sets without a tetrahedron are left out."""
    out: dict[str, list] = {}
    offsets, start = [], 0
    for t, data in blocks:
        offsets.append(start if t == cell else -1)
        start += len(data) if t == cell else 0

    def add(name, b, rows):
        if offsets[b] >= 0 and len(rows):
            out.setdefault(name, []).append(offsets[b] + rows)

    for name, b, rows in _set_rows(m, dim=3):
        add(name, b, rows)
    for b, pid in enumerate((m.cell_data or {}).get("nastran:ref") or []):
        for value in np.unique(pid):
            add(f"PID{int(value)}", b, np.flatnonzero(pid == value))
    return {n: np.unique(np.concatenate(rows)) for n, rows in out.items()}


def _groups(m, blocks, new: np.ndarray, where: str) -> dict[str, np.ndarray]:
    """Node groups of the solid, by name: point sets as they are, cell sets as the nodes of
    their cells (any cell kind: a surface set names the face nodes), gmsh physical groups
    by their names. Nodes outside the solid are dropped; a set left empty is said."""
    out: dict[str, set] = {}

    def add(name, nodes):
        nodes = new[np.asarray(nodes, dtype=np.int64).ravel()]
        out.setdefault(str(name), set()).update(nodes[nodes >= 0].tolist())

    for name, idx in (m.point_sets or {}).items():
        add(name, idx)
    for name, b, rows in _set_rows(m):
        add(name, blocks[b][1][rows])
    empty = sorted(n for n, s in out.items() if not s)
    if empty:
        logger.info("%s: sets %s have no node on the solid", where, empty)
    return {n: np.array(sorted(s), dtype=np.int64) for n, s in out.items() if s}


def check_units(mesh: MeshData, positions: Mapping[str, np.ndarray], units: str, where: str,
                expected_mass: float | None = None, mass: float | None = None) -> None:
    """Catch a mesh read in the wrong length unit.

    Every position the spec gives in metres (``positions``: what -> (3,)) must lie within
    the mesh's bounding box grown by half its diagonal; and, where the spec states the
    link's ``expected_mass`` (kg), the mesh's ``mass`` must agree within 5 %. Either failing
    is one line naming the unit the file would need.
    """
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    pad = 0.5 * diag
    for what, p in positions.items():
        p = np.asarray(p, dtype=float)
        if np.any(p < lo - pad) or np.any(p > hi + pad):
            guess = _likely_unit(diag, float(np.linalg.norm(p - 0.5 * (lo + hi))), units)
            raise ConfigError(
                f"{where}: {what} at {np.round(p, 6).tolist()} m lies outside the mesh, whose "
                f"bounding box is {np.round(lo, 6).tolist()} to {np.round(hi, 6).tolist()} m "
                f"read in geometry.units {units!r}{guess}")
    if expected_mass is not None and mass is not None and \
            abs(mass - expected_mass) > 0.05 * expected_mass:
        ratio = mass / expected_mass
        hint = ""
        for u, s in UNITS.items():
            # a file in u read as units: lengths times UNITS[units] / s, mass that cubed
            if u != units and 0.9 < ratio * (s / UNITS[units]) ** 3 < 1.1:
                hint = f"; is the file in {u!r} (geometry.units)?"
        raise ConfigError(f"{where}: the mesh's mass {mass:.6g} kg is {ratio:.3g} times "
                          f"geometry.expected_mass {expected_mass:.6g} kg{hint}")


def _likely_unit(diag: float, distance: float, units: str) -> str:
    """'; is the file in 'mm'?' for the unit whose rescaling of the mesh would bring it
    closest to the size of the distance that failed (within a factor of 10)."""
    best, score = "", np.log(10.0)
    for u, s in UNITS.items():
        if u == units:
            continue
        off = abs(np.log(max(distance, 1e-300) / max(diag * s / UNITS[units], 1e-300)))
        if off < score:
            best, score = f"; is the file in {u!r}?", off
    return best
