"""Triangulated boxes and cylinders for pictures of links that have no mesh (numpy only)."""

from __future__ import annotations

import numpy as np

from pipeline.core.errors import ConfigError


def box_surface(size, center=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(8, 3) corner points (m) and (12, 3) outward triangles of an axis-aligned box.

    Examples
    --------
    >>> p, t = box_surface([2.0, 1.0, 1.0])
    >>> p.shape, t.shape, float(np.ptp(p[:, 0]))
    ((8, 3), (12, 3), 2.0)
    """
    size = np.asarray(size, dtype=float)
    if size.shape != (3,) or np.any(size <= 0):
        raise ConfigError(f"box size: expected three positive lengths, m, got {size.tolist()}")
    corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (-0.5, 0.5)])
    points = corners * size + np.asarray(center, dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tri = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=int)
    return points, tri


def cylinder_surface(start, end, radius: float, n: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """(2 n + 2, 3) points (m) and (4 n, 3) triangles of a closed cylinder from start to end."""
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    if length <= 0 or radius <= 0:
        raise ConfigError(f"cylinder: expected distinct ends and radius > 0, got length "
                          f"{length} m, radius {radius} m")
    z = axis / length
    x = np.eye(3)[np.argmin(np.abs(z))]
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    ang = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    ring = radius * (np.outer(np.cos(ang), x) + np.outer(np.sin(ang), y))
    points = np.vstack([a + ring, b + ring, a, b])
    tri = []
    for i in range(n):
        j = (i + 1) % n
        tri += [(i, j, n + j), (i, n + j, n + i), (2 * n, j, i), (2 * n + 1, n + i, n + j)]
    return points, np.array(tri, dtype=int)
