"""Re-express link data in the body frame (the reference interface's frame).

With H the (4, 4) pose of the body frame in the geometry frame, homogeneous
points map as r_b = H^-1 r and mode fields (fourth component 0) as
phi_b = H^-1 phi, so every mass-distribution matrix transforms congruently:
C_b = H^-1 C H^-T (likewise C'_a and C''_ab). Exact, no re-integration.
"""

from __future__ import annotations

import numpy as np


def pose(origin: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(4, 4) homogeneous pose from an origin (3,) and axes (3, 3) (columns x, y, z)."""
    H = np.eye(4)
    H[:3, :3] = axes
    H[:3, 3] = origin
    return H


def inverse_pose(H: np.ndarray) -> np.ndarray:
    """Inverse of a rigid (4, 4) pose."""
    Hi = np.eye(4)
    Hi[:3, :3] = H[:3, :3].T
    Hi[:3, 3] = -H[:3, :3].T @ H[:3, 3]
    return Hi


def congruent(Hi: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Hi @ X @ Hi^T over the last two axes of X (..., 4, 4)."""
    return np.einsum("ij,...jk,lk->...il", Hi, X, Hi)


def points_to_body(H: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, 3) points from the geometry frame to the body frame."""
    R, o = H[:3, :3], H[:3, 3]
    return (np.asarray(points) - o) @ R


def vectors_to_body(H: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """(..., 3) free vectors (displacements, small rotations) to the body frame."""
    return np.asarray(vectors) @ H[:3, :3]
