"""The FE mesh of a reduced link, written for other FE tools.

A link meshed here can be checked, or carried on, in the FE code a company trusts: its
solid mesh (the quadratic or linear tetrahedra the reduction used, with their midside
nodes where they are) goes out as Abaqus/CalculiX ``.inp`` or Nastran bulk data ``.bdf``
(both written here) or through meshio as gmsh ``.msh`` or ``.vtu``, in the link's
geometry frame (the frame its spec is written in) and in metres. Read back as
``geometry: {type: mesh, path: ..., units: m}`` with the same interfaces, it reduces to the
same link (:mod:`pipeline.meshing.imported`). An ``.inp`` also names each interface's nodes
(``*NSET``, by the group its selector picked and by the interface), so a spec whose
interfaces select gmsh groups selects the same nodes from it; Nastran bulk data has no
named node sets, and meshio's ``.msh`` and ``.vtu`` are written without them.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import ConfigError
from pipeline.invariants.reduced_link import ReducedLink

__all__ = ["MESH_EXPORTS", "node_sets", "write_link_mesh"]

logger = logging.getLogger(__name__)

#: file suffix -> format (Abaqus and Nastran written here: CalculiX reads 20 characters of
#: a field, and meshio's Nastran writer cut negative coordinates short of 16)
MESH_EXPORTS = {".inp": "abaqus", ".bdf": "nastran", ".msh": "gmsh", ".vtu": "vtu"}


def write_link_mesh(link: ReducedLink, path: str | Path) -> Path:
    """Write ``link``'s solid mesh to ``path`` (format by suffix, :data:`MESH_EXPORTS`): its
    nodes in the geometry frame, m, and its tetrahedra (meshio order). Returns the path.

    Raises ConfigError for a beam link (its mesh is line elements with sections, which
    the import does not take) or an unknown suffix."""
    import meshio

    path = Path(path)
    fmt = MESH_EXPORTS.get(path.suffix.lower())
    if fmt is None:
        raise ConfigError(f"{path}: a link's mesh is written as {', '.join(MESH_EXPORTS)}, "
                          f"not {path.suffix or 'a file without a suffix'}")
    if link.kind != "solid":
        raise ConfigError(f"link {link.name!r}: only a solid link's mesh is written (a beam's "
                          "is line elements with sections)")
    cells = np.asarray(link.cells, dtype=np.int64)
    kind = {10: "tetra10", 4: "tetra"}.get(cells.shape[1])
    if kind is None:
        raise ConfigError(f"link {link.name!r}: cells of {cells.shape[1]} nodes are no "
                          "tetrahedra")
    H = np.asarray(link.body_pose, dtype=float)
    points = link.nodes @ H[:3, :3].T + H[:3, 3]  # body frame -> geometry frame
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        if fmt == "abaqus":
            sets = node_sets(link)
            if not sets:
                logger.info("%s: no node sets of the interfaces: link %r was reduced before "
                            "they were kept (pipeline reduce --rebuild adds them)", path,
                            link.name)
            _write_inp(tmp, link.name, points, cells, sets)
        elif fmt == "nastran":
            _write_bdf(tmp, link.name, points, cells)
        else:
            meshio.write(tmp, meshio.Mesh(points, [(kind, cells)]), file_format=fmt)
    return path


def node_sets(link: ReducedLink) -> dict[str, np.ndarray]:
    """Name -> node indices (into ``link.nodes``) of each interface's FE nodes: named by
    the mesh group its selector picked (so the link's own spec selects them again from
    the written file) and by the interface; empty for an artifact made before they were
    kept."""
    sets: dict[str, np.ndarray] = {}
    taken: set[str] = set()  # an FE tool's set names ignore case
    for row in link.meta.get("interface_nodes", ()):
        nodes = np.asarray(row["nodes"], dtype=np.int64)
        for name in (row["group"], row["interface"]):
            if name and name.upper() not in taken:
                sets[name] = nodes
                taken.add(name.upper())
    return sets


def _write_inp(path: Path, name: str, points: np.ndarray, cells: np.ndarray,
               sets: dict[str, np.ndarray]) -> None:
    """An Abaqus/CalculiX input of the mesh: ``*NODE`` (1-based, each coordinate in the
    most digits that fit 20 characters: CalculiX reads no more of a field, and meshio's 24
    would be cut), ``*ELEMENT`` as C3D10 or C3D4 (meshio's C3D10MH is Abaqus' hybrid
    element, which CalculiX does not take) in an element set named by the link, for the
    FE tool's ``*SOLID SECTION``, and a ``*NSET`` of each of ``sets`` (16 per line, as
    Abaqus reads them): the interfaces' nodes, for the FE tool's loads and supports."""
    kind = "C3D10" if cells.shape[1] == 10 else "C3D4"
    with open(path, "w") as fh:
        fh.write(f"*HEADING\nlink {name}: FE mesh, metres\n*NODE, NSET=NALL\n")
        fh.writelines(f"{i}, " + ", ".join(_field(float(x)) for x in p) + "\n"
                      for i, p in enumerate(points, start=1))
        fh.write(f"*ELEMENT, TYPE={kind}, ELSET={name.upper()}\n")
        fh.writelines(f"{e}, " + ", ".join(map(str, nodes)) + "\n"
                      for e, nodes in enumerate(cells + 1, start=1))
        for set_name, nodes in sets.items():
            fh.write(f"*NSET, NSET={set_name}\n")
            ids = nodes + 1
            fh.writelines(", ".join(map(str, ids[k:k + 16])) + "\n"
                          for k in range(0, ids.size, 16))


def _field(x: float, width: int = 20, nastran: bool = False) -> str:
    """x in the most significant digits (17 at most) that fit ``width`` characters (an
    Abaqus field's 20 that CalculiX reads; a Nastran large field's 16, where a real keeps
    its decimal point and writes its exponent short: 1.25-3). Six digits always fit."""
    for digits in range(17, 5, -1):
        text = f"{x:#.{digits}g}" if nastran else f"{x:.{digits}g}"
        if nastran and "e" in text:
            mantissa, exponent = text.split("e")
            text = f"{mantissa}{int(exponent):+d}"
        if len(text) <= width:
            return text
    raise ValueError(f"{x!r} does not fit a field of {width} characters")


def _write_bdf(path: Path, name: str, points: np.ndarray, cells: np.ndarray) -> None:
    """Nastran bulk data of the mesh: ``GRID*`` in large field (16 characters a coordinate,
    in the most digits that fit: 12-15) and ``CTETRA`` in small field with a continuation
    for the midside nodes (Nastran's node order is meshio's), every element of property 1,
    for the FE tool's ``PSOLID 1`` and ``MAT1`` (the file has no material, as the .inp)."""
    with open(path, "w") as fh:
        fh.write(f"$ link {name}: FE mesh, metres; elements of property 1 (add PSOLID 1 and "
                 "its MAT1)\nBEGIN BULK\n")
        fh.writelines(f"GRID*   {i:<16d}{'':16}{_large(p[0])}{_large(p[1])}*\n"
                      f"*       {_large(p[2])}\n" for i, p in enumerate(points, start=1))
        for e, nodes in enumerate(cells + 1, start=1):
            head = "".join(f"{k:<8d}" for k in (e, 1, *nodes[:6]))
            fh.write(f"CTETRA  {head}" + ("+\n+       " + "".join(f"{k:<8d}" for k in nodes[6:])
                                           if len(nodes) > 6 else "") + "\n")
        fh.write("ENDDATA\n")


def _large(x: float) -> str:
    """x as a real in a Nastran large field: 16 characters, right-aligned."""
    return f"{_field(x, 16, nastran=True):>16}"
