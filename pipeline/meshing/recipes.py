"""Solid link recipes: parameters -> OCC geometry in an open gmsh model.

Each entry of :data:`MESH_RECIPES` is a function
``recipe(gmsh, params, path, where) -> {group name: [(dim, tag), ...]}``:
it validates ``params`` (raising :class:`ConfigError` that names ``where``,
the field and what was expected), builds the solid with the OpenCASCADE
kernel of the *already initialised* gmsh module it is given, synchronises,
and returns the entities of its named groups (the caller turns them into
physical groups). The gmsh module is passed in, never imported here:
:mod:`pipeline.meshing.gmsh_build` is the only module that imports gmsh.

All lengths are metres, all frames are the link frame the FE model and the
interfaces use.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError, MeshError
from pipeline.core.input_files import MAX_CAD_BYTES, MAX_SCRIPT_BYTES, input_file
from pipeline.meshing.geo_scan import check_geo_script
from pipeline.meshing.recipe_params import (
    check_keys,
    check_plate_bores,
    parse_bent_plate,
    parse_box_bores,
    parse_plate_bores,
    positive,
)

Groups = dict[str, list[tuple[int, int]]]
Recipe = Callable[[Any, Mapping[str, Any], "Path | None", str], Groups]


def bar(gmsh, params: Mapping[str, Any], path: Path | None, where: str) -> Groups:
    """Prismatic bar: x in [0, L], section b (y) x h (z) centred on the x axis.

    Parameters (``params``): ``L``, ``b``, ``h`` in m.
    Groups: ``end_x0`` (face x = 0), ``end_xL`` (face x = L).
    """
    check_keys(params, where, required=("L", "b", "h"))
    L, b, h = (positive(params, k, where) for k in ("L", "b", "h"))
    occ = gmsh.model.occ
    occ.addBox(0.0, -b / 2, -h / 2, L, b, h)
    occ.synchronize()
    return {"end_x0": _plane_faces(gmsh, 0, 0.0, L), "end_xL": _plane_faces(gmsh, 0, L, L)}


def plate_with_bores(gmsh, params: Mapping[str, Any], path: Path | None, where: str) -> Groups:
    """Flat plate with through pin bores along z.

    Outline x in [0, length], y in [-width/2, width/2] (corners optionally
    rounded with ``corner_radius``), thickness z in [-thickness/2, thickness/2].

    Parameters (``params``): ``length``, ``width``, ``thickness`` (m),
    optional ``bores``: list of ``{name, center: [x, y], radius}`` (m),
    optional ``corner_radius`` (m, default 0).
    Groups: ``bore_<name>`` (the cylindrical bore surface).
    """
    check_keys(params, where, required=("length", "width", "thickness"),
               optional=("bores", "corner_radius"))
    length, width, t = (positive(params, k, where) for k in ("length", "width", "thickness"))
    rc = float(params.get("corner_radius", 0.0) or 0.0)
    if not (0.0 <= rc < min(length, width) / 2):
        raise ConfigError(f"{where}: params.corner_radius: expected a value in "
                          f"[0, {min(length, width) / 2}), got {params['corner_radius']!r}")
    bores = parse_plate_bores(params.get("bores", []) or [], where)
    check_plate_bores(bores, length, width, rc, where)
    occ = gmsh.model.occ
    if rc > 0:
        rect = occ.addRectangle(0.0, -width / 2, -t / 2, length, width, roundedRadius=rc)
        plate = [e for e in occ.extrude([(2, rect)], 0, 0, t) if e[0] == 3]
    else:
        plate = [(3, occ.addBox(0.0, -width / 2, -t / 2, length, width, t))]
    return _cut_z_bores(gmsh, plate, bores, t, where)


def bent_plate(gmsh, params: Mapping[str, Any], path: Path | None, where: str) -> Groups:
    """Dog-leg side plate of a loader lift arm (or, with two points, a straight link plate in
    any direction), in the plane z = 0.

    The outline is the polyline of pivot points (pivot, knee(s), tip) swept
    by a disc: straight strips of ``width`` along each member, joined at every
    knee by a disc of diameter ``knee_width`` (>= width, a boss around the
    knee pin), with half-round ends (or square ends if ``rounded_ends`` is
    false). Thickness z in [-thickness/2, thickness/2].

    Parameters (``params``): ``points`` (k >= 2, 2) [[x, y], ...] m;
    ``width``, ``thickness`` m; optional ``point_names`` (k names, default
    ``p0``, ``p1``, ...), ``knee_width`` m, ``rounded_ends`` (default true),
    ``bores``: list of ``{name, radius, at: <point or lug name>}`` or
    ``{name, radius, center: [x, y]}``; ``lugs``: list of ``{name, root, center: [x, y],
    width}``, a tab of ``width`` from ``root`` (a point name or [x, y] inside the
    members) to a half-round end at ``center``, for a pin off the centre lines (a
    cylinder eye).
    Groups: ``bore_<name>`` for every bore.

    Examples
    --------
    A 1.9 m tractor-loader arm: pivot on the tower, knee 1.2 m ahead and
    0.25 m lower, bucket pin 0.75 m further down::

        points: [[0, 0], [1.2, -0.25], [1.75, -0.8]]
        point_names: [pivot, knee, tip]
        width: 0.16, knee_width: 0.24, thickness: 0.02
        bores: [{name: pivot, at: pivot, radius: 0.025},
                {name: cyl, at: knee, radius: 0.02},
                {name: tip, at: tip, radius: 0.02}]
    """
    arm = parse_bent_plate(params, where)
    occ = gmsh.model.occ
    z0, t = -arm.thickness / 2, arm.thickness
    pieces = [_strip(occ, p, q, arm.width, z0) for p, q in zip(arm.points[:-1], arm.points[1:])]
    for i, p in enumerate(arm.points):
        end = i in (0, len(arm.points) - 1)
        if end and not arm.rounded_ends:
            continue
        r = arm.width / 2 if end else arm.knee_width / 2
        pieces.append((2, occ.addDisk(float(p[0]), float(p[1]), z0, r, r)))
    for g in arm.lugs:
        pieces.append(_strip(occ, np.array(g.root), np.array(g.center), g.width, z0))
        pieces.append((2, occ.addDisk(*g.center, z0, g.width / 2, g.width / 2)))
    outline, _ = occ.fuse(pieces[:1], pieces[1:])
    plate = [e for e in occ.extrude(outline, 0, 0, t) if e[0] == 3]
    return _cut_z_bores(gmsh, plate, arm.bores, t, where)


def box_section(gmsh, params: Mapping[str, Any], path: Path | None, where: str) -> Groups:
    """Hollow rectangular tube along x in [0, length], outer b (y) x h (z).

    Parameters (``params``): ``length``, ``b``, ``h``, ``wall`` (m);
    optional ``end_plates`` (bool, default false: open ends) with
    ``end_plate_thickness`` (m, default ``wall``); ``cross_bores``: list of
    ``{name, x, radius, axis: "y" | "z", offset}`` -- a bore along ``axis``
    through both walls normal to it, at station ``x``, shifted by ``offset``
    (m, default 0) along the other transverse axis.
    Groups: ``end_x0``, ``end_xL`` (the end faces: wall rings or plates),
    ``bore_<name>`` (both cylindrical surfaces of the cross bore).
    """
    check_keys(params, where, required=("length", "b", "h", "wall"),
               optional=("end_plates", "end_plate_thickness", "cross_bores"))
    L, b, h, wall = (positive(params, k, where) for k in ("length", "b", "h", "wall"))
    if wall >= min(b, h) / 2:
        raise ConfigError(f"{where}: params.wall: expected a value < min(b, h)/2 = "
                          f"{min(b, h) / 2}, got {wall!r}")
    closed = bool(params.get("end_plates", False))
    tp = positive(params, "end_plate_thickness", where) if "end_plate_thickness" in params \
        else wall
    if closed and 2 * tp >= L:
        raise ConfigError(f"{where}: params.end_plate_thickness: expected < length/2, got {tp!r}")
    bores = parse_box_bores(params.get("cross_bores", []) or [], L, b, h, wall,
                            tp if closed else 0.0, where)
    occ = gmsh.model.occ
    outer = occ.addBox(0.0, -b / 2, -h / 2, L, b, h)
    x0, dx = (tp, L - 2 * tp) if closed else (-L, 3 * L)  # open: cut through both ends
    inner = occ.addBox(x0, -b / 2 + wall, -h / 2 + wall, dx, b - 2 * wall, h - 2 * wall)
    tube, _ = occ.cut([(3, outer)], [(3, inner)])
    tools = []
    for bore in bores:
        c = [bore.x, 0.0, 0.0]
        k = 1 if bore.axis == "y" else 2
        c[3 - k] = bore.offset
        c[k] = -max(b, h)
        axis = [0.0, 0.0, 0.0]
        axis[k] = 2 * max(b, h)
        tools.append((3, occ.addCylinder(*c, *axis, bore.radius)))
    if tools:
        occ.cut(tube, tools)
    occ.synchronize()
    groups = {"end_x0": _plane_faces(gmsh, 0, 0.0, L), "end_xL": _plane_faces(gmsh, 0, L, L)}
    for bore in bores:
        k = 1 if bore.axis == "y" else 2
        lo = [bore.x - bore.radius, -b / 2, -h / 2]
        hi = [bore.x + bore.radius, b / 2, h / 2]
        lo[3 - k], hi[3 - k] = bore.offset - bore.radius, bore.offset + bore.radius
        groups[f"bore_{bore.name}"] = _cylinder_faces(gmsh, lo, hi, bore.radius, where)
    return groups


def geo_file(gmsh, params: Mapping[str, Any], path: Path | None, where: str) -> Groups:
    """Load a gmsh ``.geo`` script; its named physical groups become the groups. Scripts
    that run programs, read other scripts, write files or exit are refused
    (:func:`pipeline.meshing.geo_scan.check_geo_script`).

    No parameters. Use ``SetFactory("OpenCASCADE")`` in the file to get the
    exact CAD mass properties in ``MeshData.cad``.
    """
    check_keys(params, where)
    path = _existing(path, where, (".geo",))
    check_geo_script(path, where)
    gmsh.merge(str(path))
    return {}


def step_file(gmsh, params: Mapping[str, Any], path: Path | None, where: str) -> Groups:
    """Import the solids of a STEP file (converted to metres by OCC).

    Parameters (``params``): optional ``heal`` (bool, default false: run
    OCC shape healing). No groups: select interfaces geometrically.
    """
    check_keys(params, where, optional=("heal",))
    path = _existing(path, where, (".step", ".stp"))
    gmsh.option.setString("Geometry.OCCTargetUnit", "M")
    shapes = gmsh.model.occ.importShapes(str(path))
    if params.get("heal", False):
        gmsh.model.occ.healShapes(shapes)
    gmsh.model.occ.synchronize()
    if not gmsh.model.getEntities(3):
        raise MeshError(f"{where}: STEP file {path} contains no solid")
    return {}


MESH_RECIPES: dict[str, Recipe] = {
    "bar": bar,
    "plate_with_bores": plate_with_bores,
    "bent_plate": bent_plate,
    "box_section": box_section,
    "geo": geo_file,
    "step": step_file,
}


# --- geometric identification of faces after the booleans (tags are renumbered) ---

def _cut_z_bores(gmsh, plate: list[tuple[int, int]], bores, t: float, where: str) -> Groups:
    occ = gmsh.model.occ
    tools = [(3, occ.addCylinder(b.center[0], b.center[1], -t, 0, 0, 2 * t, b.radius))
             for b in bores]
    if tools:
        occ.cut(plate, tools)
    occ.synchronize()
    return {f"bore_{b.name}": _cylinder_faces(
        gmsh, [b.center[0] - b.radius, b.center[1] - b.radius, -t / 2],
        [b.center[0] + b.radius, b.center[1] + b.radius, t / 2], b.radius, where) for b in bores}


def _strip(occ, p: np.ndarray, q: np.ndarray, width: float, z0: float) -> tuple[int, int]:
    """Rectangle of ``width`` centred on the segment p -> q (m) in the plane z = z0."""
    d = q - p
    rect = occ.addRectangle(0.0, -width / 2, z0, float(np.hypot(*d)), width)
    occ.rotate([(2, rect)], 0, 0, 0, 0, 0, 1, float(np.arctan2(d[1], d[0])))
    occ.translate([(2, rect)], float(p[0]), float(p[1]), 0.0)
    return (2, rect)


def _pad(gmsh, size: float) -> float:
    # OCC bounding boxes are enlarged by the shape tolerance; pad relative to the feature.
    return 1e-3 * size + 10 * gmsh.option.getNumber("Geometry.Tolerance")


def _plane_faces(gmsh, axis: int, value: float, size: float) -> list[tuple[int, int]]:
    """Faces lying in the plane x_axis = value (within a small pad)."""
    eps, big = _pad(gmsh, size), 1e3 * size + 1.0
    lo, hi = [-big] * 3, [big] * 3
    lo[axis], hi[axis] = value - eps, value + eps
    return list(gmsh.model.getEntitiesInBoundingBox(*lo, *hi, 2))


def _cylinder_faces(gmsh, lo, hi, radius: float, where: str) -> list[tuple[int, int]]:
    """Cylindrical faces fully inside the box [lo, hi] (padded)."""
    eps = _pad(gmsh, radius)
    inside = gmsh.model.getEntitiesInBoundingBox(*(np.asarray(lo) - eps),
                                                 *(np.asarray(hi) + eps), 2)
    faces = [e for e in inside if gmsh.model.getType(*e) == "Cylinder"]
    if not faces:
        raise MeshError(f"{where}: no cylindrical bore face of radius {radius} found in the "
                        f"box {lo}..{hi} after the boolean cut")
    return faces


def _existing(path: Path | None, where: str, suffixes: tuple[str, ...]) -> Path:
    if path is None:
        raise ConfigError(f"{where}: geometry.path: expected a {'/'.join(suffixes)} file")
    p = Path(path)
    if not p.exists():
        raise MeshError(f"{where}: geometry file not found: {p}")
    if p.suffix.lower() not in suffixes:
        raise ConfigError(f"{where}: geometry.path: expected a {'/'.join(suffixes)} file, "
                          f"got {p.name}")
    limit = MAX_SCRIPT_BYTES if p.suffix.lower() == ".geo" else MAX_CAD_BYTES
    try:
        return input_file(p, "geometry file", limit)
    except ConfigError as exc:
        raise ConfigError(f"{where}: geometry.path: {exc}") from None
