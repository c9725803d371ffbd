"""Boundary extraction and tet orientation on hand-made meshes (no gmsh)."""

import numpy as np

from pipeline.meshing.gmsh_build import TET10_GMSH_TO_MESHIO
from pipeline.meshing.mesh_data import boundary_faces
from pipeline.meshing.mesh_data import orient_tets as _orient
from tests.meshing.conftest import TET10_EDGES, signed_tet_volumes

# unit cube split into 6 positively oriented tets around the diagonal 0-6
CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                 [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
CUBE_TETS = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6],
                      [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]])


def _p2(points, tets):
    """Add edge midpoints in meshio tetra10 order (independent construction)."""
    pts = [*points]
    conn = []
    for t in tets:
        row = list(t)
        for a, b in TET10_EDGES:
            pts.append((points[t[a]] + points[t[b]]) / 2)
            row.append(len(pts) - 1)
        conn.append(row)
    return np.array(pts), np.array(conn)


def test_cube_boundary_is_12_outward_triangles_of_total_area_6():
    tets = _orient(CUBE, CUBE_TETS)
    assert signed_tet_volumes(CUBE, tets).min() > 0
    tri = boundary_faces(tets)
    assert tri.shape == (12, 3)
    p = CUBE[tri]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) / 2
    np.testing.assert_allclose(np.linalg.norm(n, axis=1).sum(), 6.0)
    # outward: normal points away from the cube centre
    assert np.all(np.einsum("ij,ij->i", p.mean(axis=1) - 0.5, n) > 0)


def test_orient_flips_inverted_tet10_with_its_edge_nodes():
    pts, tets = _p2(CUBE, CUBE_TETS)
    bad = tets.copy()
    # invert tets 0 and 3 by swapping vertices 1 and 2 and fixing the edge nodes by geometry
    for k in (0, 3):
        v = bad[k, [0, 2, 1, 3]]
        mids = {frozenset((a, b)): m for (a, b), m in
                zip([(tets[k, i], tets[k, j]) for i, j in TET10_EDGES], tets[k, 4:])}
        bad[k] = np.r_[v, [mids[frozenset((v[i], v[j]))] for i, j in TET10_EDGES]]
    assert (signed_tet_volumes(pts, bad) < 0).sum() == 2
    fixed = _orient(pts, bad)
    assert signed_tet_volumes(pts, fixed).min() > 0
    for i, (a, b) in enumerate(TET10_EDGES):  # each edge node is still its edge's midpoint
        np.testing.assert_allclose(pts[fixed[:, 4 + i]], (pts[fixed[:, a]] + pts[fixed[:, b]]) / 2)
    tri6 = boundary_faces(fixed)
    assert tri6.shape == (12, 6)
    for i, (a, b) in enumerate([(0, 1), (1, 2), (2, 0)]):
        np.testing.assert_allclose(pts[tri6[:, 3 + i]], (pts[tri6[:, a]] + pts[tri6[:, b]]) / 2)


def test_gmsh_to_meshio_tet10_permutation_matches_meshio():
    from meshio.gmsh.common import _gmsh_to_meshio_order

    idx = np.arange(10)[None, :]
    np.testing.assert_array_equal(_gmsh_to_meshio_order("tetra10", idx)[0], TET10_GMSH_TO_MESHIO)
