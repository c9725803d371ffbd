"""Shared checks for meshes built in the meshing tests."""

import numpy as np


def signed_tet_volumes(points, tets):
    """Independent of the library: 1/6 det[p1-p0, p2-p0, p3-p0] for each tet."""
    p = points[tets[:, :4]]
    return np.linalg.det(np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]],
                                  axis=1)) / 6.0


# meshio tetra10 edge nodes: 4:(0,1) 5:(1,2) 6:(0,2) 7:(0,3) 8:(1,3) 9:(2,3)
TET10_EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]


def _tet10_grad(xi):
    """Gradients (10, 3) of the meshio-ordered tet10 shape functions at reference point xi."""
    L = np.array([1 - xi.sum(), *xi])
    dL = np.vstack([-np.ones(3), np.eye(3)])  # dL_i / dxi
    g = [(4 * L[i] - 1) * dL[i] for i in range(4)]
    g += [4 * (L[a] * dL[b] + L[b] * dL[a]) for a, b in TET10_EDGES]
    return np.array(g)


# vertices, edge midpoints, face centroids and centroid of the reference tet
_REF = np.vstack([np.eye(3), np.zeros((1, 3))])
SAMPLES = np.vstack([_REF, [(_REF[a] + _REF[b]) / 2 for a in range(4) for b in range(a)],
                     [(_REF.sum(0) - _REF[k]) / 3 for k in range(4)], [_REF.mean(0)]])


def min_p2_jacobian(points, tets):
    """Smallest det(dx/dxi) of curved tet10 elements over the sample points."""
    x = points[tets]  # (k, 10, 3)
    return min(np.linalg.det(np.einsum("kni,nj->kij", x, _tet10_grad(s))).min()
               for s in SAMPLES)


def assert_valid_solid(mesh):
    """Positive tets, every point used, closed outward boundary (divergence theorem)."""
    (cell, tets), = mesh.cells.items()
    assert cell == ("tetra10" if mesh.order == 2 else "tetra")
    vol = signed_tet_volumes(mesh.points, tets)
    assert vol.min() > 0.0
    if mesh.order == 2:
        assert min_p2_jacobian(mesh.points, tets) > 0.0
    np.testing.assert_array_equal(np.unique(tets), np.arange(mesh.n_points))
    (face, tri), = mesh.boundary.items()
    assert face == ("triangle6" if mesh.order == 2 else "triangle")
    p = mesh.points[tri[:, :3]]
    area_normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) / 2  # outward * area
    # closed: sum of n dA = 0; outward: (1/3) sum x . n dA = volume of the straight tets
    scale = np.abs(area_normal).sum()
    assert np.abs(area_normal.sum(axis=0)).max() < 1e-10 * scale
    flux = np.einsum("ij,ij->", p.mean(axis=1), area_normal) / 3
    np.testing.assert_allclose(flux, vol.sum(), rtol=1e-10)
    return vol
