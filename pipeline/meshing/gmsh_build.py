"""Geometry -> :class:`MeshData` with gmsh (the only module that imports gmsh).

gmsh is imported inside the functions, initialised for one build in a
uniquely named model and always finalised afterwards (also on error), so no
gmsh state leaks between links, tests or threads.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import logging
import uuid
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError, MeshError, PipelineError
from pipeline.core.progress import stage
from pipeline.meshing.budget import MeshBudget, check_mesh_budget, mesh_in_child
from pipeline.meshing.geometry import BeamGeometry, SolidGeometry
from pipeline.meshing.imported import MeshFileGeometry, read_mesh
from pipeline.meshing.mesh_data import MeshData, boundary_faces, orient_tets
from pipeline.meshing.recipes import MESH_RECIPES

logger = logging.getLogger(__name__)

#: gmsh element type ids of the linear and quadratic tetrahedron and line.
GMSH_TET = {1: 4, 2: 11}
GMSH_LINE = 1
#: gmsh tet10 node order -> meshio/VTK order: gmsh numbers the last two edge
#: nodes (3, 2) and (3, 1), meshio (1, 3) and (2, 3) (cf. meshio.gmsh.common).
TET10_GMSH_TO_MESHIO = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])
#: Vertex pairs of the tet10 edge nodes 4..9 in gmsh's order.
_GMSH_TET10_EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)]
#: Meshing options measured fastest on the 2-core machine (tests/meshing/
#: test_bench_mesh.py, P2 bar 0.4 x 0.008 x 0.004 m, mesh_size 2.05 mm, 18 600
#: nodes, whole build_mesh): HXT 3D (10) 0.29 s, Delaunay (1) 0.49 s, Frontal (4)
#: 0.64 s. Two HXT threads gain ~15 % but make the mesh non-deterministic and
#: compete with the other processes for the 2 cores, so one thread.
MESH_OPTIONS: dict[str, float] = {
    "Mesh.Algorithm": 6,  # Frontal-Delaunay 2D
    "Mesh.Algorithm3D": 10,  # HXT
    "Mesh.MaxNumThreads3D": 1,
    "General.NumThreads": 1,
    "Mesh.Optimize": 1,
}


def build_mesh(geometry: SolidGeometry | BeamGeometry | MeshFileGeometry, name: str, *,
               options: Mapping[str, float] | None = None, budget: MeshBudget | None = None,
               isolate: bool = True) -> MeshData:
    """Mesh one link's geometry with gmsh (or read a mesh file: :mod:`imported`).

    Parameters
    ----------
    geometry : SolidGeometry or BeamGeometry
        What to mesh (SI units, link frame).
    name : str
        Link name, used in messages and the gmsh model name.
    options : Mapping[str, float], optional
        Numeric gmsh options overriding :data:`MESH_OPTIONS` (solids only),
        e.g. ``{"Mesh.Algorithm3D": 10}``.
    budget : MeshBudget, optional
        Wall time and memory a solid's meshing may take (default: 600 s and the memory
        available).
    isolate : bool
        Mesh a solid in a child process held to ``budget`` (default; see
        :mod:`pipeline.meshing.budget`). False meshes in this process, unbounded (for
        the child itself, and for callers that already run in a bounded process).

    Returns
    -------
    MeshData
        Solid: ``cells {"tetra10": (k, 10)}`` (meshio order) or
        ``{"tetra": (k, 4)}``, ``boundary {"triangle6" | "triangle": ...}``
        (outward), ``groups`` physical-group name -> node ids, ``cad`` OCC
        mass properties per unit density. Beam: ``cells {"line": (k, 2)}``
        along the polyline, groups per named vertex and ``member_<i>``.

    Raises
    ------
    ConfigError
        Bad recipe parameters.
    MeshError
        Missing geometry file, gmsh failure, empty or invalid mesh.

    Examples
    --------
    >>> mesh = build_mesh(SolidGeometry("bar", {"L": 0.1, "b": 0.01, "h": 0.01}, 0.01, 1),
    ...                   "demo")  # doctest: +SKIP
    >>> mesh.cells["tetra"].shape[1]  # doctest: +SKIP
    4
    """
    if isinstance(geometry, SolidGeometry):
        opts = {**MESH_OPTIONS, **(options or {})}
        build = functools.partial(mesh_in_child, options=opts, budget=budget or MeshBudget()) \
            if isolate else functools.partial(build_solid, options=opts)
    elif isinstance(geometry, BeamGeometry):
        build = _build_beam
    elif isinstance(geometry, MeshFileGeometry):
        build = read_mesh
    else:
        raise ConfigError(f"link {name!r}: geometry: expected SolidGeometry, BeamGeometry or "
                          f"MeshFileGeometry, got {type(geometry).__name__}")
    with stage(f"meshing link '{name}'"):
        return build(geometry, name)


@contextlib.contextmanager
def _signals_kept() -> Iterator[None]:
    """Keep this process's SIGPIPE disposition across gmsh's initialisation, which resets
    it to the default (terminate): Python ignores SIGPIPE and raises BrokenPipeError
    instead, and after a mesh made in-process a write to a closed socket (a Dask worker
    killed under a study's client) killed the whole process without a word. Restorable
    only from the main thread (signal.signal's rule); meshing runs there."""
    import signal
    import threading

    pipe = getattr(signal, "SIGPIPE", None)
    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(pipe) if pipe is not None and main else None
    try:
        yield
    finally:
        if before is not None:
            signal.signal(pipe, before)


@contextlib.contextmanager
def gmsh_session(name: str) -> Iterator[Any]:
    """Yield the gmsh module, initialised with a fresh model; finalise on exit.

    If the caller already has gmsh initialised, only the model made here is
    removed on exit and the caller's current model restored (global gmsh
    options set here stay changed). gmsh exceptions become :class:`MeshError`
    with gmsh's message and the link name.
    """
    try:
        import gmsh
    except ImportError as exc:  # pragma: no cover - gmsh is an extra
        raise MeshError("gmsh is not installed: install pipeline[mesh]") from exc
    owned = not gmsh.isInitialized()
    if owned:
        with _signals_kept():
            gmsh.initialize(readConfigFiles=False, interruptible=False)
    previous = None if owned else gmsh.model.getCurrent()
    try:
        gmsh.option.setNumber("General.Terminal", int(logger.isEnabledFor(logging.DEBUG)))
        gmsh.model.add(f"{name}-{uuid.uuid4().hex[:8]}")
        yield gmsh
    except PipelineError:
        raise
    except Exception as exc:  # gmsh raises bare Exception with its last error
        raise MeshError(f"link {name!r}: gmsh failed: {exc}") from exc
    finally:
        if owned:
            gmsh.finalize()
        else:
            gmsh.model.remove()
            gmsh.model.setCurrent(previous)


def build_solid(geometry: SolidGeometry, name: str, options: Mapping[str, float],
                memory: int | None = None) -> MeshData:
    """Mesh a solid in this process (unbounded: see :func:`build_mesh`); the mesh estimated
    before meshing must fit in ``memory`` bytes (default: the memory available)."""
    where = f"link {name!r}"
    check_extent(geometry.params, where)
    with gmsh_session(name) as gmsh:
        groups = MESH_RECIPES[geometry.recipe](gmsh, geometry.params, geometry.path, where)
        if not gmsh.model.getEntities(3):
            raise MeshError(f"{where}: geometry {geometry.recipe!r} has no volume to mesh")
        for gname, entities in groups.items():
            for dim in sorted({d for d, _ in entities}):
                tags = [t for d, t in entities if d == dim]
                gmsh.model.addPhysicalGroup(dim, tags, name=gname)
        check_mesh_budget(_geometry_volume(gmsh), geometry.mesh_size, geometry.order, where,
                          memory)
        _set_mesh_options(gmsh, options, geometry.mesh_size, geometry.order)
        gmsh.model.mesh.generate(3)
        if geometry.order == 2:
            gmsh.model.mesh.setOrder(2)
            _check_jacobians(gmsh, where)
        points, tets, tags = _volume_mesh(gmsh, geometry.order, where)
        group_nodes = _physical_group_nodes(gmsh, tags, where)
        cad = _cad_properties(gmsh)
    tets = orient_tets(points, tets)
    cell, face = ("tetra10", "triangle6") if geometry.order == 2 else ("tetra", "triangle")
    return MeshData(points=points, cells={cell: tets}, kind="solid", order=geometry.order,
                    boundary={face: boundary_faces(tets)}, groups=group_nodes, cad=cad,
                    source=f"gmsh:{geometry.recipe}" + (f":{geometry.path}"
                                                        if geometry.path else ""))


#: the largest coordinate or length a recipe takes, m (a link larger than 10 km is a typo,
#: and OCC would build it before any mesh budget is asked)
MAX_EXTENT = 1.0e4


def check_extent(params, where: str, path: str = "params") -> None:
    """ConfigError for a recipe parameter beyond :data:`MAX_EXTENT`, checked before OCC
    builds anything (a point at 1e30 m used to build a 1e30 m plate first; the mesh budget,
    :func:`check_mesh_budget`, needs the built volume)."""
    if isinstance(params, Mapping):
        for k, v in params.items():
            check_extent(v, where, f"{path}.{k}")
    elif isinstance(params, (list, tuple)):
        for i, v in enumerate(params):
            check_extent(v, where, f"{path}[{i}]")
    elif isinstance(params, (int, float)) and not isinstance(params, bool) and \
            not abs(params) <= MAX_EXTENT:
        raise ConfigError(f"{where}: {path}: {params!r} m is beyond the recipes' range "
                          f"(at most {MAX_EXTENT:g} m)")


def _geometry_volume(gmsh) -> float:
    """Volume of the model's solids, m^3 (the OCC kernel's; else their bounding box)."""
    vol = 0.0
    for dim, tag in gmsh.model.getEntities(3):
        try:
            vol += abs(gmsh.model.occ.getMass(dim, tag))
        except Exception:  # noqa: BLE001 - gmsh raises plain Exception (built-in kernel: no
            # mass; the bounding box bounds it)
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(dim, tag)
            vol += (x1 - x0) * (y1 - y0) * (z1 - z0)
    return vol


def _set_mesh_options(gmsh, options: Mapping[str, float], size: float, order: int) -> None:
    for key, value in options.items():
        gmsh.option.setNumber(key, value)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
    gmsh.option.setNumber("Mesh.ElementOrder", order)
    gmsh.option.setNumber("Mesh.SecondOrderLinear", 0)  # edge nodes on the CAD surfaces


def _check_jacobians(gmsh, where: str) -> None:
    """Curving P2 edges onto the CAD can invert elements at coarse curved faces.

    gmsh's exact (Bezier) minimum scaled Jacobian finds them; their edge
    nodes are moved back to the straight-edge midpoints (the element becomes
    locally straight-sided, off the CAD by the chord error). gmsh's own
    high-order optimiser is not used: it aborts the process when it fails.
    """
    tags, node_tags = gmsh.model.mesh.getElementsByType(GMSH_TET[2])
    conn = np.asarray(node_tags, dtype=np.int64).reshape(-1, 10)
    n_fixed = 0
    for _ in range(4):
        bad = np.asarray(gmsh.model.mesh.getElementQualities(tags, "minSJ")) <= 0.0
        if not bad.any():
            break
        n_fixed += int(bad.sum())
        for k, (a, b) in enumerate(_GMSH_TET10_EDGES):
            for mid, ta, tb in conn[bad][:, [4 + k, a, b]]:
                xa, xb = (np.asarray(gmsh.model.mesh.getNode(int(t))[0]) for t in (ta, tb))
                gmsh.model.mesh.setNode(int(mid), list((xa + xb) / 2), [])
    else:
        raise MeshError(f"{where}: the second-order mesh has inverted curved elements; "
                        "reduce geometry.mesh_size or use order 1")
    if n_fixed:
        logger.warning("%s: straightened %d curved tetrahedra that were inverted (curved faces "
                       "too coarse for mesh_size)", where, n_fixed)


def _volume_mesh(gmsh, order: int, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points used by the tetrahedra (renumbered 0..n-1), tets, and old tag per point."""
    etype = GMSH_TET[order]
    other = sorted(set(gmsh.model.mesh.getElementTypes(3)) - {etype})
    if other:
        names = [gmsh.model.mesh.getElementProperties(t)[0] for t in other]
        raise MeshError(f"{where}: expected only order-{order} tetrahedra, the mesh also has "
                        f"{names}")
    _, node_tags = gmsh.model.mesh.getElementsByType(etype)
    if len(node_tags) == 0:
        raise MeshError(f"{where}: gmsh produced an empty volume mesh "
                        "(check the geometry and mesh_size)")
    n_per = 4 if order == 1 else 10
    conn = np.asarray(node_tags, dtype=np.int64).reshape(-1, n_per)
    if order == 2:
        conn = conn[:, TET10_GMSH_TO_MESHIO]
    all_tags, coords, _ = gmsh.model.mesh.getNodes()
    all_tags = np.asarray(all_tags, dtype=np.int64)
    xyz = np.asarray(coords, dtype=float).reshape(-1, 3)
    used = np.unique(conn)  # sorted gmsh tags, the new numbering follows their order
    lookup = np.full(int(max(all_tags.max(), used.max())) + 1, -1, dtype=np.int64)
    lookup[all_tags] = np.arange(all_tags.size)
    if np.any(lookup[used] < 0):
        raise MeshError(f"{where}: gmsh elements refer to unknown nodes")
    points = xyz[lookup[used]]
    lookup[:] = -1
    lookup[used] = np.arange(used.size)
    return points, lookup[conn], lookup


def _physical_group_nodes(gmsh, lookup: np.ndarray, where: str) -> dict[str, np.ndarray]:
    """Named physical group -> sorted new node ids (high-order nodes included)."""
    groups: dict[str, np.ndarray] = {}
    for dim, tag in gmsh.model.getPhysicalGroups():
        gname = gmsh.model.getPhysicalName(dim, tag) or f"physical_{dim}_{tag}"
        node_tags = np.asarray(gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)[0],
                               dtype=np.int64)
        node_tags = node_tags[node_tags < lookup.size]
        ids = lookup[node_tags]
        ids = np.unique(ids[ids >= 0])
        if ids.size == 0:
            logger.warning("%s: physical group %r has no mesh nodes", where, gname)
        groups[gname] = np.union1d(groups.get(gname, np.empty(0, np.int64)), ids)
    return groups


def _cad_properties(gmsh) -> dict[str, np.ndarray]:
    """OCC mass properties per unit density, summed over the volumes.

    ``occ.getMatrixOfInertia`` returns the inertia tensor about the volume's
    own centroid, I_c = tr(S_c) 1 - S_c (checked against a rotated box in the
    tests), so S_c = tr(I_c)/2 1 - I_c and S = sum(S_c + V c c^T).
    """
    volume, first, second = 0.0, np.zeros(3), np.zeros((3, 3))
    for dim, tag in gmsh.model.getEntities(3):
        try:
            v = gmsh.model.occ.getMass(dim, tag)
            c = np.asarray(gmsh.model.occ.getCenterOfMass(dim, tag))
            inertia = np.asarray(gmsh.model.occ.getMatrixOfInertia(dim, tag)).reshape(3, 3)
        except Exception:  # noqa: BLE001 - gmsh raises bare Exception for a non-OCC volume
            logger.debug("volume %d is not an OpenCASCADE entity: no CAD properties", tag)
            return {}
        volume += v
        first += v * c
        second += np.trace(inertia) / 2 * np.eye(3) - inertia + v * np.outer(c, c)
    if volume <= 0.0:
        return {}
    return {"volume": np.array(volume), "centroid": first / volume,
            "second_moment": (second + second.T) / 2}


#: most elements of a beam link (a 6-DOF-per-node model: 6e6 DOF)
MAX_BEAM_ELEMENTS = 1_000_000


def _build_beam(geometry: BeamGeometry, name: str) -> MeshData:
    where = f"link {name!r}"
    pts = geometry.points
    lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    expected = np.ceil(lengths / geometry.element_size - 1e-9)
    if expected.sum() > MAX_BEAM_ELEMENTS:
        raise MeshError(f"{where}: element_size {geometry.element_size:g} m on "
                        f"{lengths.sum():.4g} m of beam would give {expected.sum():.3g} "
                        f"elements, more than {MAX_BEAM_ELEMENTS}: use a larger element_size")
    with gmsh_session(name) as gmsh:
        geo = gmsh.model.geo
        ptags = [geo.addPoint(*map(float, p), geometry.element_size) for p in pts]
        ltags = [geo.addLine(a, b) for a, b in itertools.pairwise(ptags)]
        geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", geometry.element_size)
        gmsh.model.mesh.generate(1)
        all_tags, coords, _ = gmsh.model.mesh.getNodes()
        xyz = dict(zip(np.asarray(all_tags, np.int64), np.asarray(coords).reshape(-1, 3)))
        members = [np.asarray(gmsh.model.mesh.getElements(1, t)[2][0], np.int64).reshape(-1, 2)
                   if gmsh.model.mesh.getElements(1, t)[2] else np.empty((0, 2), np.int64)
                   for t in ltags]
    for i, (conn, n) in enumerate(zip(members, expected)):
        if conn.shape[0] < n:  # gmsh gives up silently on sizes it cannot honour
            raise MeshError(f"{where}: gmsh made {conn.shape[0]} elements on member {i} where "
                            f"element_size {geometry.element_size:g} m asks for {n:.0f}")
    return _beam_mesh(geometry, members, xyz, where)


def _beam_mesh(geometry: BeamGeometry, members: list[np.ndarray], xyz: dict,
               where: str) -> MeshData:
    """Number the nodes along the polyline and order the line cells the same way."""
    pts = geometry.points
    order: list[int] = []  # gmsh node tags along the polyline
    member_nodes = []
    for i, conn in enumerate(members):
        if conn.size == 0:
            raise MeshError(f"{where}: gmsh produced no elements on member {i}")
        tags = np.unique(conn)
        d = pts[i + 1] - pts[i]
        s = np.array([(xyz[t] - pts[i]) @ d for t in tags])
        tags = tags[np.argsort(s)]
        start = len(order) - 1 if order else 0
        order.extend(int(t) for t in (tags[1:] if order else tags))
        member_nodes.append(np.arange(start, len(order)))
    new = {t: k for k, t in enumerate(order)}
    cells = np.sort(np.vectorize(new.get)(np.concatenate(members)), axis=1)
    cells = cells[np.argsort(cells[:, 0])]
    if not np.array_equal(cells, np.column_stack([np.arange(len(order) - 1),
                                                  np.arange(1, len(order))])):
        raise MeshError(f"{where}: the beam mesh is not a single chain along the polyline")
    groups = {f"member_{i}": ids for i, ids in enumerate(member_nodes)}
    vertex_ids = [0] + [int(ids[-1]) for ids in member_nodes]
    groups.update({n: np.array([vertex_ids[k]]) for k, n in enumerate(geometry.vertex_names)})
    return MeshData(points=np.array([xyz[t] for t in order]), cells={"line": cells},
                    kind="beam", order=1, source="gmsh:beam", groups=groups)
