"""Stiffness and mass matrices computed by another FE code, as a :class:`FemModel`.

Where a company's FE code (CalculiX, Abaqus) has assembled the link's model, its free-free
K and M come in as they are, beside the mesh they belong to, and the reduction runs on
them exactly as on a model assembled here: interfaces tied, modes clamped or
Craig-Bampton, the mass invariants from the model's own mass operator. Two file forms:

* ``calculix``: ``*FREQUENCY, SOLVER=MATRIXSTORAGE`` writes ``job.sti`` and ``job.mas``
  (upper triangles, ``row col value``, 1-based) and ``job.dof`` (``node.direction`` of
  each row); run it without ``*BOUNDARY`` for the free-free model.
* ``abaqus``: ``*MATRIX GENERATE, STIFFNESS, MASS`` with ``*MATRIX OUTPUT, FORMAT=
  COORDINATE`` writes ``job_STIF1.mtx`` and ``job_MASS1.mtx``, one entry a line as
  ``node_i, dof_i, node_j, dof_j, value`` (the format Exudyn reads).

Node numbers are those of the FE code's input file (``*NODE``), which is also the mesh
file; each is matched to the mesh's point at the same coordinates. Units: the file's
length unit (the mesh's) and its mass unit (kg, t, g; a consistent set, so that K is in
mass units / s^2): K and M are scaled by the mass unit.

What matrices cannot give is said, not made up: stress modes and geometric stiffness need
the element formulation, which the matrices do not carry.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import MeshError
from pipeline.fem.model import FemModel
from pipeline.meshing.imported import MASS_UNITS, MatrixFiles
from pipeline.meshing.mesh_data import MeshData

__all__ = ["input_node_points", "read_matrices"]

#: mass unit -> kg
#: the largest matrix file read, bytes
MAX_MATRIX_BYTES = 4 * 2**30


def read_matrices(files: MatrixFiles, mesh: MeshData, length_scale: float,
                  name: str) -> FemModel:
    """The free-free :class:`FemModel` of ``files`` on ``mesh`` (its points in m; the FE
    code's node coordinates are in the file unit, ``length_scale`` m each).

    Raises MeshError for unreadable or inconsistent files: a node of the matrices not in
    the mesh, a mesh node without its three translations, K or M not symmetric, M not the
    same scalar mass in x, y and z (what the mass invariants are computed from).
    """
    where = f"link {name!r}: geometry.matrices"
    for p in files.files():
        if not p.is_file():
            raise MeshError(f"{where}: {p}: no such file")
        if p.stat().st_size > MAX_MATRIX_BYTES:
            raise MeshError(f"{where}: {p}: larger than {MAX_MATRIX_BYTES / 2**30:.0f} GB")
    point_of_id = input_node_points(files.nodes_from, mesh, length_scale, where)
    if files.format == "calculix":
        rows = _calculix_dofs(files.dofs, where)
        K = _triplets(files.stiffness, len(rows), where)
        M = _triplets(files.mass, len(rows), where)
    else:
        rows, K, M = _abaqus_pair(files.stiffness, files.mass, where)
    node_dofs = np.full((mesh.n_points, 3), -1, dtype=np.int64)
    for r, (node, d) in enumerate(rows):
        if d > 3:
            raise MeshError(f"{where}: row {r + 1} is degree of freedom {d} of node {node}; "
                            "a solid's nodes have translations 1-3 only")
        if node not in point_of_id:
            raise MeshError(f"{where}: node {node} of the matrices is not in "
                            f"{files.nodes_from.name}")
        node_dofs[point_of_id[node], d - 1] = r
    missing = np.flatnonzero((node_dofs < 0).any(axis=1))
    if missing.size:
        raise MeshError(f"{where}: {missing.size} mesh nodes have no rows in the matrices "
                        f"(e.g. the node at {np.round(mesh.points[missing[0]], 6).tolist()} m): "
                        "write the free-free model (no *BOUNDARY) of the whole solid")
    s = MASS_UNITS[files.mass_unit]
    K, M = (K * s).tocsr(), (M * s).tocsr()
    for A, what in ((K, "stiffness"), (M, "mass")):
        asym = abs(A - A.T).max() if A.nnz else 0.0
        if asym > 1e-9 * abs(A).max():
            raise MeshError(f"{where}: the {what} matrix is not symmetric")
    Ms = _scalar_mass(M, node_dofs, where)
    boundary = np.unique(next(iter(mesh.boundary.values()))) if mesh.boundary else \
        np.arange(mesh.n_points)
    cells = next(iter(mesh.cells.values()))
    extras = {"scalar_mass": Ms, "boundary_nodes": boundary, "cells": cells,
              "source": f"{files.format} matrices {files.stiffness.name}, {files.mass.name}"}
    return FemModel(name=name, kind="solid", nodes=mesh.points.copy(), node_dofs=node_dofs,
                    stiffness=K, mass=M, extras=extras)


def input_node_points(path: Path, mesh: MeshData, length_scale: float,
                      where: str) -> dict[int, int]:
    """{node number of the FE input ``path`` (its ``*NODE`` lines): index of the mesh point
    at its coordinates} (``length_scale`` m per file unit): how another code's results on
    that input (matrices, mode files) find the mesh's nodes.

    Raises MeshError when the input has no ``*NODE`` lines or a mesh point no node."""
    ids, coords = _inp_nodes(path, where)
    return _match_nodes(ids, coords * length_scale, mesh.points, where)


def _inp_nodes(path: Path, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(ids (n,), coordinates (n, 3)) of the ``*NODE`` lines of an Abaqus/CalculiX input."""
    ids, xyz = [], []
    inside = False
    with open(path, encoding="utf-8", errors="replace") as f:
        for k, line in enumerate(f, 1):
            s = line.strip()
            if not s or s.startswith("**"):
                continue
            if s.startswith("*"):
                inside = s.split(",")[0].strip().upper() == "*NODE"
                continue
            if inside:
                parts = [p for p in s.split(",") if p.strip()]
                try:
                    ids.append(int(parts[0]))
                    xyz.append([float(v) for v in parts[1:4]] + [0.0] * (4 - len(parts)))
                except (ValueError, IndexError):
                    raise MeshError(f"{where}: {path.name}:{k}: expected 'id, x, y, z' in "
                                    f"*NODE, got {s[:60]!r}") from None
    if not ids:
        raise MeshError(f"{where}: {path.name}: no *NODE lines")
    return np.array(ids), np.array(xyz, dtype=float)


def _match_nodes(ids, coords, points, where) -> dict[int, int]:
    """{FE node id: mesh point index} by coordinates (the same nodes in both files)."""
    from scipy.spatial import cKDTree

    size = float(np.ptp(points, axis=0).max()) or 1.0
    dist, idx = cKDTree(points).query(coords)
    out = {}
    for i, d, j in zip(ids, dist, idx, strict=True):
        if d <= 1e-9 * size:
            out[int(i)] = int(j)
    if len(set(out.values())) < points.shape[0]:
        raise MeshError(f"{where}: {points.shape[0] - len(set(out.values()))} mesh points are "
                        "no node of the FE input (another mesh, or another length unit?)")
    return out


def _calculix_dofs(path: Path, where: str) -> list[tuple[int, int]]:
    rows = []
    for k, line in enumerate(path.read_text(errors="replace").split(), 1):
        m = re.fullmatch(r"(\d+)\.(\d)", line)
        if m is None:
            raise MeshError(f"{where}: {path.name}:{k}: expected 'node.direction', got "
                            f"{line[:40]!r}")
        rows.append((int(m.group(1)), int(m.group(2))))
    return rows


def _triplets(path: Path, n: int, where: str) -> sp.csr_matrix:
    """A symmetric matrix from ``row col value`` lines (1-based) of one triangle (CalculiX
    writes the upper) or both."""
    try:
        data = np.loadtxt(path, ndmin=2)
    except ValueError as exc:
        raise MeshError(f"{where}: {path.name}: expected 'row col value' lines ({exc})") \
            from None
    if data.shape[1] != 3:
        raise MeshError(f"{where}: {path.name}: expected 3 columns, got {data.shape[1]}")
    i, j = data[:, 0].astype(np.int64) - 1, data[:, 1].astype(np.int64) - 1
    if i.size and (min(i.min(), j.min()) < 0 or max(i.max(), j.max()) >= n):
        raise MeshError(f"{where}: {path.name}: indices outside 1..{n} (the .dof file's rows)")
    return _symmetric(sp.coo_matrix((data[:, 2], (i, j)), shape=(n, n)).tocsr())


def _symmetric(A: sp.csr_matrix) -> sp.csr_matrix:
    """The symmetric matrix of entries given as one triangle (completed by its transpose)
    or as both (kept)."""
    upper, lower = sp.triu(A, k=1), sp.tril(A, k=-1)
    if upper.nnz and lower.nnz:
        return A
    return A + (upper.T if upper.nnz else lower.T)


def _abaqus_pair(stiffness: Path, mass: Path, where: str):
    """(rows [(node, dof)], K, M) of Abaqus coordinate-format .mtx files (node, dof, node,
    dof, value; the lower or upper triangle, or both)."""
    tables = []
    for path in (stiffness, mass):
        try:
            data = np.loadtxt(path, delimiter=",", ndmin=2, comments="*")
        except ValueError as exc:
            raise MeshError(f"{where}: {path.name}: expected 'node, dof, node, dof, value' "
                            f"lines ({exc})") from None
        if data.shape[1] != 5:
            raise MeshError(f"{where}: {path.name}: expected 5 columns, got {data.shape[1]}")
        tables.append(data)
    keys = np.unique(np.concatenate([np.concatenate([t[:, 0:2], t[:, 2:4]])
                                     for t in tables]).astype(np.int64), axis=0)
    index = {(int(a), int(b)): r for r, (a, b) in enumerate(keys)}
    n = len(keys)
    out = []
    for t in tables:
        i = np.array([index[int(a), int(b)] for a, b in t[:, 0:2]], dtype=np.int64)
        j = np.array([index[int(a), int(b)] for a, b in t[:, 2:4]], dtype=np.int64)
        out.append(_symmetric(sp.coo_matrix((t[:, 4], (i, j)), shape=(n, n)).tocsr()))
    return [tuple(map(int, k)) for k in keys], out[0], out[1]


def _scalar_mass(M: sp.csr_matrix, node_dofs: np.ndarray, where: str) -> sp.csr_matrix:
    """The scalar mass M_s with M = M_s in each of x, y, z and no coupling between them (a
    consistent or lumped mass of translational nodes), from which the invariants come."""
    blocks = [M[node_dofs[:, a]][:, node_dofs[:, b]] for a in range(3) for b in range(3)]
    Ms = blocks[0]
    scale = abs(Ms).max()
    for a in range(3):
        for b in range(3):
            B = blocks[3 * a + b]
            ref = Ms if a == b else 0 * Ms
            if abs(B - ref).max() > 1e-9 * scale:
                raise MeshError(f"{where}: the mass matrix is not the same scalar mass in x, "
                                f"y and z (block {'xyz'[a]}{'xyz'[b]} differs): the mass "
                                "invariants need a translational mass of that form")
    return Ms.tocsr()
