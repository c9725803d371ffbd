"""Rotations and homogeneous 4x4 transforms.

Conventions: a pose H (4, 4) maps homogeneous coordinates of a point in the
moving frame to the reference frame, H = [[R, p], [0, 1]] with R (3, 3) the
axes of the moving frame (columns) and p (3,) its origin, in m. Angles in rad.
``skew(w) @ v == cross(w, v)``; ``vee`` is its inverse on the skew part.

Examples
--------
>>> import numpy as np
>>> H = homogeneous(rot_z(np.pi / 2), [1.0, 0.0, 0.0])
>>> np.allclose(H @ [1.0, 0.0, 0.0, 1.0], [1.0, 1.0, 0.0, 1.0])
True
>>> np.allclose(inverse(H) @ H, np.eye(4))
True
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "GENERATORS",
    "exp_so3",
    "frame_from_z",
    "homogeneous",
    "inverse",
    "log_so3",
    "rot_x",
    "rot_y",
    "rot_z",
    "skew",
    "translation",
    "vee",
]


def skew(w) -> np.ndarray:
    """(3, 3) cross-product matrix of w (3,): ``skew(w) @ v == np.cross(w, v)``."""
    x, y, z = (float(c) for c in w)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def vee(S: np.ndarray) -> np.ndarray:
    """(..., 3) axial vector of the skew part of S (..., 3, 3)."""
    S = np.asarray(S)
    return 0.5 * np.stack(
        [S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]],
        axis=-1,
    )


def rot_x(a: float) -> np.ndarray:
    """(3, 3) rotation by ``a`` rad about x."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """(3, 3) rotation by ``a`` rad about y."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    """(3, 3) rotation by ``a`` rad about z."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def homogeneous(R=None, p=None) -> np.ndarray:
    """(4, 4) pose from a rotation R (3, 3) (default identity) and origin p (3,), m."""
    H = np.eye(4)
    if R is not None:
        H[:3, :3] = R
    if p is not None:
        H[:3, 3] = p
    return H


def translation(p) -> np.ndarray:
    """(4, 4) pure translation by p (3,), m."""
    return homogeneous(None, p)


def inverse(H: np.ndarray) -> np.ndarray:
    """Inverse (4, 4) of a rigid pose (orthonormal rotation block)."""
    Hi = np.eye(4)
    Rt = H[:3, :3].T
    Hi[:3, :3] = Rt
    Hi[:3, 3] = -Rt @ H[:3, 3]
    return Hi


def exp_so3(w) -> np.ndarray:
    """(3, 3) rotation exp([w]x) by |w| rad about w/|w| (Rodrigues)."""
    w = np.asarray(w, dtype=float)
    a = float(np.linalg.norm(w))
    K = skew(w)
    if a < 1e-8:  # series to O(a^3): exact to round-off here
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + math.sin(a) / a * K + (1.0 - math.cos(a)) / a**2 * K @ K


def log_so3(R: np.ndarray) -> np.ndarray:
    """(3,) rotation vector w with exp_so3(w) == R, |w| in [0, pi]."""
    R = np.asarray(R, dtype=float)
    c = max(-1.0, min(1.0, 0.5 * (np.trace(R) - 1.0)))
    a = math.acos(c)
    v = vee(R)
    if a < 1e-6:
        return v * (1.0 + a * a / 6.0)
    if math.pi - a > 1e-6:
        return v * (a / math.sin(a))
    # near pi the skew part vanishes: the symmetric part is c 1 + (1 - c) n n^T
    B = (0.5 * (R + R.T) - c * np.eye(3)) / (1.0 - c)
    k = int(np.argmax(np.diag(B)))
    n = B[:, k] / math.sqrt(max(B[k, k], 1e-300))
    if np.dot(n, v) < 0.0:
        n = -n
    return a * n


def frame_from_z(origin, z_axis, x_hint=(1.0, 0.0, 0.0)) -> np.ndarray:
    """(4, 4) pose with origin (3,), z along ``z_axis`` and x as close to ``x_hint``."""
    z = np.asarray(z_axis, dtype=float)
    z = z / np.linalg.norm(z)
    x = np.asarray(x_hint, dtype=float)
    x = x - np.dot(x, z) * z
    if np.linalg.norm(x) < 1e-9:
        x = np.array([0.0, 1.0, 0.0]) - z[1] * z
    x = x / np.linalg.norm(x)
    return homogeneous(np.column_stack([x, np.cross(z, x), z]), origin)


def _generator(kind: str, axis: int) -> np.ndarray:
    Q = np.zeros((4, 4))
    if kind == "R":
        e = np.zeros(3)
        e[axis] = 1.0
        Q[:3, :3] = skew(e)
    else:
        Q[axis, 3] = 1.0
    return Q


#: Constant 4x4 derivative operators: d/dq rot_a(q) = rot_a(q) Q = Q rot_a(q) (same for
#: translations), keyed by ("R" | "T", axis 0..2).
GENERATORS = {(k, a): _generator(k, a) for k in "RT" for a in range(3)}
for _Q in GENERATORS.values():
    _Q.setflags(write=False)
