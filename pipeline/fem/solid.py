"""Solid links: P2 tetrahedra (linear elasticity, consistent mass) and their
mass-distribution moments.

Node numbering of the :class:`~pipeline.fem.model.FemModel`:

* ``"tetra10"`` meshes keep ``MeshData.points`` as they are (vertices and
  midside nodes, same order), so physical groups stay valid; the geometry is
  isoparametric (skfem ``MeshTet2``), straight elements are integrated as
  affine ones.
* ``"tetra"`` meshes: the points first, then the edge midpoints in skfem's
  edge order (skfem ``MeshTet``, straight P2).

DOF numbers come from skfem's ``Dofs`` of ``ElementVector(ElementTetP2())``
(``nodal_dofs``, ``edge_dofs``), so a skfem basis on :func:`p2_topology`'s
mesh uses the same numbering as the model.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import MeshError
from pipeline.core.progress import stage
from pipeline.fem.material import Material, assign_materials, check_material
from pipeline.fem.model import FemModel
from pipeline.fem.moments import MassMoments
from pipeline.fem.p2_kernel import EDGES, assemble_p2, vector_mass
from pipeline.meshing.mesh_data import MeshData

logger = logging.getLogger(__name__)

# Midside-node order of a 10-node tetrahedron after the 4 vertices.
MIDSIDE_ORDERS = {
    "meshio": EDGES,  # meshio / VTK and skfem ElementTetP2
    "gmsh": EDGES[:4] + (EDGES[5], EDGES[4]),  # gmsh: (2, 3) before (1, 3)
}
# A midside node closer than this (relative to its edge) to the chord
# midpoint makes a straight edge.
_STRAIGHT_TOL = 1e-12


@dataclass(frozen=True)
class P2Topology:
    """skfem view of a solid mesh and its map to the model's node numbers.

    Attributes
    ----------
    mesh : skfem MeshTet1 or MeshTet2
        The skfem mesh (vertices renumbered 0..nv-1 for ``tetra10``).
    node_of_skfem : (n_nodes,) int
        Model node id of skfem P2 node s (vertices, then edges).
    conn : (n_cells, 10) int
        skfem P2 node ids per element, ``ElementTetP2`` local order.
    coords : (n_nodes, 3) float
        Coordinates of the skfem P2 nodes, m.
    straight : (n_cells,) bool
        Elements whose midside nodes lie on the chords (affine).
    """

    mesh: object
    node_of_skfem: np.ndarray
    conn: np.ndarray
    coords: np.ndarray
    straight: np.ndarray

    @property
    def n_vertices(self) -> int:
        return int(self.mesh.t.max()) + 1


def p2_topology(mesh: MeshData, where: str) -> P2Topology:
    """Build the skfem P2 view of a ``"tetra10"`` or ``"tetra"`` mesh.

    Raises
    ------
    MeshError
        If the mesh has no tetrahedra, unused points, an inconsistent
        10-node connectivity or degenerate (zero-volume) elements.
    """
    if mesh.kind != "solid":
        raise MeshError(f"{where}: mesh.kind: expected 'solid', got {mesh.kind!r}")
    if "tetra10" in mesh.cells:
        topo = _quadratic_topology(mesh.points, np.asarray(mesh.cells["tetra10"], np.int64), where)
    elif "tetra" in mesh.cells:
        topo = _linear_topology(mesh.points, np.asarray(mesh.cells["tetra"], np.int64), where)
    else:
        raise MeshError(f"{where}: mesh.cells: expected 'tetra10' or 'tetra' cells, "
                        f"got {sorted(mesh.cells)}")
    _check_volumes(topo, where)
    return topo


def _linear_topology(points: np.ndarray, tets: np.ndarray, where: str) -> P2Topology:
    from skfem import MeshTet1

    _check_all_used(tets, points.shape[0], where)
    m = MeshTet1(points.T.copy(), tets.T.copy())
    coords = np.vstack([points, points[m.edges.T].mean(axis=1)])
    conn = np.vstack([m.t, m.p.shape[1] + m.t2e]).T
    return P2Topology(m, np.arange(coords.shape[0]), conn, coords,
                      np.ones(conn.shape[0], bool))


def _quadratic_topology(points: np.ndarray, tets: np.ndarray, where: str) -> P2Topology:
    from skfem import MeshTet1, MeshTet2
    from skfem.refdom import RefTet

    if tets.ndim != 2 or tets.shape[1] != 10:
        raise MeshError(f"{where}: mesh.cells['tetra10']: expected shape (n, 10), got {tets.shape}")
    _check_all_used(tets, points.shape[0], where)
    vertices, t = np.unique(tets[:, :4], return_inverse=True)
    t = t.reshape(-1, 4).T
    nv = vertices.size
    m1 = MeshTet1(points[vertices].T.copy(), t.copy())
    if not (np.array_equal(m1.t, t) and np.array_equal(RefTet.edges, EDGES)):
        raise MeshError(f"{where}: skfem reordered the tetrahedra; cannot map midside nodes")
    # t2e[k, e] is the edge between local vertices EDGES[k] of cell e.
    mid_of_edge = _midside_nodes(points, tets, m1.t2e, m1.edges.shape[1], where)
    node_of_skfem = np.concatenate([vertices, mid_of_edge])
    if np.unique(node_of_skfem).size != points.shape[0]:
        raise MeshError(f"{where}: mesh.cells['tetra10']: expected one point per vertex and "
                        f"per edge, got {points.shape[0]} points for {nv} vertices and "
                        f"{mid_of_edge.size} edges")
    coords = points[node_of_skfem]
    # Same connectivity as m1, so skfem numbers edges and DOFs identically.
    m2 = MeshTet2(coords.T.copy(), m1.t)
    conn = np.vstack([m1.t, nv + m1.t2e]).T
    return P2Topology(m2, node_of_skfem, conn, coords, _straight(coords[conn]))


def _midside_nodes(points: np.ndarray, tets: np.ndarray, t2e: np.ndarray, n_edges: int,
                   where: str) -> np.ndarray:
    """Point id of each skfem edge's midside node, (n_edges,).

    Tries the midside conventions of :data:`MIDSIDE_ORDERS`: the right one
    gives every edge the same node from all cells around it; if several do,
    the one whose nodes lie closest to their chords' midpoints wins.
    """
    found = []
    for order in MIDSIDE_ORDERS.values():
        slots = t2e[[EDGES.index(pair) for pair in order]].T  # (n, 6) edge id per column
        mid_of_edge = np.full(n_edges, -1, np.int64)
        mid_of_edge[slots] = tets[:, 4:]
        if np.all(mid_of_edge >= 0) and np.array_equal(mid_of_edge[slots], tets[:, 4:]):
            found.append((order, mid_of_edge))
    if not found:
        raise MeshError(f"{where}: mesh.cells['tetra10']: midside nodes are not shared "
                        "consistently by neighbouring elements (unknown node order)")
    if len(found) > 1:  # e.g. a single cell: geometry decides
        found.sort(key=lambda f: _chord_offsets(points, tets, f[0]))
    return found[0][1]


def _chord_offsets(points: np.ndarray, tets: np.ndarray, order) -> float:
    """Largest distance of a midside node from its chord midpoint / chord length."""
    pairs = tets[:, np.array(order)]  # (n, 6, 2)
    chord = points[pairs[..., 1]] - points[pairs[..., 0]]
    off = points[tets[:, 4:]] - points[pairs].mean(axis=2)
    return float(np.max(np.linalg.norm(off, axis=2) / np.linalg.norm(chord, axis=2)))


def _straight(X: np.ndarray) -> np.ndarray:
    """(n,) True where every midside node of X (n, 10, 3) is on its chord."""
    e = np.array(EDGES)
    chord = X[:, e[:, 1]] - X[:, e[:, 0]]
    off = X[:, 4:] - 0.5 * (X[:, e[:, 0]] + X[:, e[:, 1]])
    return np.all(np.linalg.norm(off, axis=2) <= _STRAIGHT_TOL * np.linalg.norm(chord, axis=2),
                  axis=1)


def _check_all_used(tets: np.ndarray, n_points: int, where: str) -> None:
    if tets.size == 0 or tets.min() < 0 or tets.max() >= n_points:
        raise MeshError(f"{where}: mesh.cells: expected node ids in [0, {n_points}), "
                        f"got {tets.size} ids")
    unused = n_points - np.unique(tets).size
    if unused:
        raise MeshError(f"{where}: mesh.points: {unused} point(s) belong to no tetrahedron; "
                        "remove them before the FE stage")


def _check_volumes(topo: P2Topology, where: str) -> None:
    X = topo.coords[topo.conn[:, :4]]
    edges = X[:, 1:] - X[:, :1]
    vol = np.abs(np.linalg.det(edges)) / 6.0
    scale = np.max(np.linalg.norm(edges, axis=2), axis=1) ** 3
    bad = np.flatnonzero(vol <= 1e-12 * scale)
    if bad.size:
        raise MeshError(f"{where}: mesh.cells: {bad.size} degenerate tetrahedra "
                        f"(zero volume), first is cell {int(bad[0])}")


def assemble_solid(mesh: MeshData, material: Material, name: str,
                   materials: Mapping[str, Material] | None = None) -> FemModel:
    """Free-free P2 elasticity model of a solid link.

    Parameters
    ----------
    mesh : MeshData
        ``"tetra10"`` (curved, isoparametric) or ``"tetra"`` (straight) mesh, m.
    material : Material
        E (Pa), nu, rho (kg/m^3): the link's, for every cell ``materials`` does not give.
    name : str
        Link name, used in messages and as the model's name.
    materials : mapping of element-set name to Material, optional
        Materials of the cells of the mesh's element sets (``mesh.cell_groups``).

    Returns
    -------
    FemModel
        ``kind="solid"``; ``stiffness`` (N/m) and consistent ``mass`` (kg) CSR
        (n_dof, n_dof); ``node_dofs`` (n_nodes, 3); ``extras``:
        ``"scalar_mass"`` (n_nodes, n_nodes) CSR int rho N_i N_j dV (kg),
        ``"boundary_nodes"`` sorted surface node ids, ``"cells"`` (n_cells, 10)
        node ids in meshio/VTK ``tetra10`` order, ``"material"`` (the link's),
        ``"cell_materials"`` (a :class:`CellMaterials`: each cell's).

    Raises
    ------
    ConfigError
        Bad material; an element set the mesh does not have; a cell given two.
    MeshError
        Unusable mesh (see :func:`p2_topology`).

    Examples
    --------
    >>> from skfem import MeshTet
    >>> m = MeshTet.init_tensor(*[np.linspace(0, 1, 2)] * 3)
    >>> mesh = MeshData(m.p.T, {"tetra": m.t.T}, "solid")
    >>> model = assemble_solid(mesh, Material(1.0, 0.3, 2.0), "cube")
    >>> model.n_nodes, model.n_dof, round(float(model.extras["scalar_mass"].sum()), 12)
    (27, 81, 2.0)
    """
    where = f"link {name!r}"
    material = check_material(material, where)
    topo = p2_topology(mesh, where)
    cells = assign_materials(material, materials or {}, mesh.cell_groups, topo.conn.shape[0],
                             where)
    left = int(np.count_nonzero(cells.index == 0))
    if materials and left:  # said: a set missing from the spec (or a file's cell in no
        # section) would otherwise take the link's material unseen
        logger.warning("%s: %d of %d cells are in none of the element sets given materials "
                       "(%s); they take the link's material (E %.4g Pa, rho %.4g kg/m^3)",
                       where, left, cells.index.size, ", ".join(materials), material.E,
                       material.rho)
    if cells.uniform:
        (lam, mu), rho = material.lame, material.rho
    else:
        (lam, mu), rho = cells.lame, cells.density
    with stage(f"assembling P2 solid of {where}"):
        K, Ms = assemble_p2(topo.coords[topo.conn], topo.conn, topo.coords.shape[0],
                            lam, mu, topo.straight, rho=rho)
        M = vector_mass(Ms)
        sk_dofs = _skfem_node_dofs(topo)
        K, M = _to_skfem_numbering(K, sk_dofs), _to_skfem_numbering(M, sk_dofs)
    skfem_of_node = np.argsort(topo.node_of_skfem)
    nodes = mesh.points.copy() if "tetra10" in mesh.cells else topo.coords
    logger.info("%s: %d nodes, %d DOF, %d cells (%d curved)", where, nodes.shape[0], K.shape[0],
                topo.conn.shape[0], int(np.count_nonzero(~topo.straight)))
    extras = {
        "scalar_mass": Ms[skfem_of_node][:, skfem_of_node].tocsr(),
        "boundary_nodes": _boundary_nodes(topo),
        "cells": topo.node_of_skfem[topo.conn],
        "material": material,
        "cell_materials": cells,
    }
    return FemModel(name=name, kind="solid", nodes=nodes, node_dofs=sk_dofs[skfem_of_node],
                    stiffness=K, mass=M, extras=extras)


def _skfem_node_dofs(topo: P2Topology) -> np.ndarray:
    """(n_nodes, 3) skfem DOFs of (ux, uy, uz) of each skfem P2 node."""
    from skfem import ElementTetP2, ElementVector
    from skfem.assembly import Dofs

    dofs = Dofs(topo.mesh, ElementVector(ElementTetP2()))
    node_dofs = np.vstack([dofs.nodal_dofs.T, dofs.edge_dofs.T]).astype(np.int64)
    if dofs.N != node_dofs.size or node_dofs.shape[0] != topo.coords.shape[0]:
        raise MeshError(f"unexpected skfem P2 DOF layout: {dofs.N} DOFs for "
                        f"{topo.coords.shape[0]} nodes")
    return node_dofs


def _to_skfem_numbering(A: sp.csr_matrix, node_dofs: np.ndarray) -> sp.csr_matrix:
    """Renumber A from DOF 3 n + a to node_dofs[n, a] (usually the identity)."""
    old_of_new = np.empty(node_dofs.size, np.int64)
    old_of_new[node_dofs.ravel()] = np.arange(node_dofs.size)
    if np.array_equal(old_of_new, np.arange(node_dofs.size)):
        return A
    return A[old_of_new][:, old_of_new].tocsr()


def _boundary_nodes(topo: P2Topology) -> np.ndarray:
    """Sorted model node ids on the surface: facet vertices and facet edges."""
    m = topo.mesh
    facets = m.boundary_facets()
    skfem_ids = np.concatenate([m.facets[:, facets].ravel(),
                                topo.n_vertices + m.f2e[:, facets].ravel()])
    return np.unique(topo.node_of_skfem[skfem_ids])


def solid_moments(model: FemModel, U: np.ndarray) -> MassMoments:
    """Mass-distribution matrices C, C'_a, C''_ab of a solid's distributed mass.

    With the scalar mass M_s and nodal coordinates x (exact in P2):
    C[i, j] = x_i^T M_s x_j (x_3 = 1), C'_a[i, k] = x_i^T M_s phi_a^(k),
    C''_ab[k, l] = phi_a^(k)^T M_s phi_b^(l); the fourth column of C'_a
    and the fourth row and column of C''_ab are zero.

    Parameters
    ----------
    model : FemModel
        A solid model with ``extras["scalar_mass"]``.
    U : (n_dof, m) array
        DOF vectors (mode shapes), m.

    Returns
    -------
    MassMoments
        C (4, 4), Cp (m, 4, 4), Cpp (m, m, 4, 4); kg, kg m, kg m^2.
    """
    U = np.asarray(U, float).reshape(model.n_dof, -1)
    n_modes = U.shape[1]
    # Columns: x, y, z, 1, then phi_a^(k) ordered (a, k).
    fields = np.empty((model.n_nodes, 4 + 3 * n_modes))
    fields[:, :3] = model.nodes
    fields[:, 3] = 1.0
    fields[:, 4:] = U[model.node_dofs].transpose(0, 2, 1).reshape(model.n_nodes, -1)
    gram = fields.T @ (model.extras["scalar_mass"] @ fields)
    gram = 0.5 * (gram + gram.T)
    C = gram[:4, :4].copy()
    Cp = np.zeros((n_modes, 4, 4))
    Cp[:, :, :3] = gram[:4, 4:].reshape(4, n_modes, 3).transpose(1, 0, 2)
    Cpp = np.zeros((n_modes, n_modes, 4, 4))
    Cpp[:, :, :3, :3] = gram[4:, 4:].reshape(n_modes, 3, n_modes, 3).transpose(0, 2, 1, 3)
    return MassMoments(C, Cp, Cpp)
