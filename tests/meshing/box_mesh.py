"""A structured mesh of a box in quadratic tetrahedra, built by hand (no mesher), for the
mesh-import tests: each of nx ny nz bricks split into 6 tetrahedra around its main
diagonal, midside nodes shared by the edges' neighbours, meshio (VTK) node order."""

from __future__ import annotations

import itertools

import numpy as np

#: the 6 tetrahedra of a brick (corner k = x + 2 y + 4 z), all around the diagonal 0-7
_KUHN = [(0, 1, 3, 7), (0, 3, 2, 7), (0, 2, 6, 7), (0, 6, 4, 7), (0, 4, 5, 7), (0, 5, 1, 7)]
#: vertex pairs of the edge nodes 4..9 of a tetra10 (meshio / VTK order)
EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]


def box_tet10(L: float, b: float, h: float, n: tuple[int, int, int]):
    """(points (N, 3), tetra10 (6 nx ny nz, 10)) of [0, L] x [0, b] x [0, h], positively
    oriented."""
    nx, ny, nz = n
    xs, ys, zs = np.linspace(0, L, nx + 1), np.linspace(0, b, ny + 1), np.linspace(0, h, nz + 1)
    vid = {}
    pts = []
    for k, j, i in itertools.product(range(nz + 1), range(ny + 1), range(nx + 1)):
        vid[i, j, k] = len(pts)
        pts.append((xs[i], ys[j], zs[k]))
    tets = []
    for i, j, k in itertools.product(range(nx), range(ny), range(nz)):
        corner = [vid[i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)] for c in range(8)]
        for t in _KUHN:
            tets.append([corner[c] for c in t])
    pts = np.array(pts, dtype=float)
    tets = np.array(tets, dtype=np.int64)
    vol = np.einsum("ij,ij->i", np.cross(pts[tets[:, 1]] - pts[tets[:, 0]],
                                         pts[tets[:, 2]] - pts[tets[:, 0]]),
                    pts[tets[:, 3]] - pts[tets[:, 0]])
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    mid = {}
    out = np.zeros((len(tets), 10), dtype=np.int64)
    out[:, :4] = tets
    pts = list(pts)
    for e, t in enumerate(tets):
        for s, (a, c) in enumerate(EDGES):
            key = (min(t[a], t[c]), max(t[a], t[c]))
            if key not in mid:
                mid[key] = len(pts)
                pts.append(0.5 * (pts[t[a]] + pts[t[c]]))
            out[e, 4 + s] = mid[key]
    return np.array(pts), out
