"""Beam meshes built directly (no gmsh) for the beam tests."""

import numpy as np

from pipeline.meshing.mesh_data import MeshData


def polyline_mesh(vertices, n_per_member):
    """MeshData of a polyline with ``n_per_member`` equal line elements per member."""
    vertices = np.asarray(vertices, float)
    pts = [vertices[0]]
    for a, b in zip(vertices[:-1], vertices[1:]):
        t = np.linspace(0.0, 1.0, n_per_member + 1)[1:, None]
        pts.extend(a + t * (b - a))
    n = len(pts)
    cells = np.column_stack([np.arange(n - 1), np.arange(1, n)])
    return MeshData(points=np.array(pts), cells={"line": cells}, kind="beam")
