"""Marker points and frames of the force elements as flat arrays, and their compiled
evaluation (numba), for the compiled equations of motion.

A marker frame on link l has the pose A_l S(eta) with S(eta) = S0 + sum_a eta_a dS_a
(+ the second-order translation sum_ab eta_a eta_b H_ab / 2 of a second-order frame;
:class:`pipeline.kinematics.links.Frame`). A point at offset o in it is
R = A_l (c0 + sum_a eta_a c_a + sum_ab eta_a eta_b he_ab / 2) with c0 = r0 + R0 o and
c_a = dS_a applied to o; the frame's rotation is A_l[:3, :3] (R0 + sum_a eta_a dR_a).
The numpy form of a marker point is :func:`pipeline.dynamics.forces.base.marker_point`
(tested equal), of a frame's twist the tests' oracle (``tests/dynamics/forces_numpy.py``).

:class:`ForceData` is everything the compiled force kernels read, by name.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)

__all__ = ["ForceData", "MarkerTable", "frame_twist", "line_geometry", "line_loads",
           "load_row", "marker_frame", "marker_point", "no_potential"]

#: The force elements of a system, flat (see :func:`pipeline.dynamics.forces.compiled.
#: compile_forces`): per element its ``kind`` (F,), ``ints`` (F, 5) (markers, coordinate,
#: table rows, the offset of its own states in z or -1), ``par`` (F, >= 6) (stiffness, free
#: value, damping, force / preload and two more force components; an element may use
#: more columns), ``conservative`` (F,); ``table`` (T, 2) force-deflection rows;
#: per marker its ``link`` (Mk,), ``c0`` (Mk, 3), ``ca`` (Mk, MM, 3), ``idx`` (Mk, MM) and
#: ``n_modes`` (Mk,) of its link's modal coordinates, ``he`` (Mk, MM, MM, 3) and
#: ``n_hess`` (Mk,) its second-order translation, ``R0`` (Mk, 3, 3) and ``dR`` (Mk, MM, 3,
#: 3) its frame's rotation.
ForceData = namedtuple("ForceData", ["kind", "ints", "par", "conservative", "table", "link",
                                     "c0", "ca", "idx", "n_modes", "he", "n_hess", "R0",
                                     "dR"])


class MarkerTable:
    """The marker points the force elements use, collected while they pack themselves."""

    def __init__(self, mech):
        self.mech = mech
        self.MM = max([1] + [len(i) for i in mech.modal_index])
        self.rows: list[tuple] = []

    def add(self, marker, offset=(0.0, 0.0, 0.0)) -> int:
        """Index of the point at ``offset`` (3,) m in ``marker`` (link, frame)."""
        mech, MM = self.mech, self.MM
        link, frame = marker
        li = mech.link_index(link)
        f = mech.links[li].frame(frame)
        o = f.pose[:3, :3] @ np.asarray(offset, dtype=float)
        idx = mech.modal_index[li]
        ca, he = np.zeros((MM, 3)), np.zeros((MM, MM, 3))
        dR = np.zeros((MM, 3, 3))
        if idx.size:
            ca[:idx.size] = f.phi + np.cross(f.psi, o)
            dR[:idx.size] = f.dshape[:, :3, :3]
            if f.hess is not None:  # second-order translation (rotations: first order)
                he[:idx.size, :idx.size] = f.hess
        mi = np.zeros(MM, dtype=np.int64)
        mi[:idx.size] = idx
        self.rows.append((li, f.pose[:3, 3] + o, ca, mi, idx.size, he,
                          idx.size if f.hess is not None else 0, f.pose[:3, :3].copy(), dR))
        return len(self.rows) - 1

    def arrays(self) -> tuple:
        """(link, c0, ca, idx, n_modes, he, n_hess, R0, dR) as ForceData wants them."""
        k, MM = len(self.rows), self.MM
        col = [[r[j] for r in self.rows] for j in range(9)]
        return (np.array(col[0], dtype=np.int64).reshape(k),
                np.array(col[1], dtype=float).reshape(k, 3),
                np.array(col[2], dtype=float).reshape(k, MM, 3),
                np.array(col[3], dtype=np.int64).reshape(k, MM),
                np.array(col[4], dtype=np.int64).reshape(k),
                np.array(col[5], dtype=float).reshape(k, MM, MM, 3),
                np.array(col[6], dtype=np.int64).reshape(k),
                np.array(col[7], dtype=float).reshape(k, 3, 3),
                np.array(col[8], dtype=float).reshape(k, MM, 3, 3))


@njit(cache=True)
def marker_point(k, q, A, dA, d, p, dp):
    """p (3,) = marker point k in ground, dp (n, 3) its derivatives dp/dq (module
    docstring; A (L, 4, 4), dA (L, n, 4, 4) the link poses and their derivatives)."""
    li = d.link[k]
    loc = np.empty(3)
    for r in range(3):  # element by element: no temporary per mode
        loc[r] = d.c0[k, r]
    for a in range(d.n_modes[k]):
        qa = q[d.idx[k, a]]
        for r in range(3):
            loc[r] += qa * d.ca[k, a, r]
        for b in range(d.n_hess[k]):
            w = 0.5 * qa * q[d.idx[k, b]]
            for r in range(3):
                loc[r] += w * d.he[k, a, b, r]
    for r in range(3):
        p[r] = A[li, r, 3] + A[li, r, 0] * loc[0] + A[li, r, 1] * loc[1] + A[li, r, 2] * loc[2]
    n = q.shape[0]
    for i in range(n):
        for r in range(3):
            dp[i, r] = dA[li, i, r, 3] + dA[li, i, r, 0] * loc[0] + dA[li, i, r, 1] * loc[1] \
                + dA[li, i, r, 2] * loc[2]
    ca = np.empty(3)
    for a in range(d.n_modes[k]):
        i = d.idx[k, a]
        for r in range(3):
            ca[r] = d.ca[k, a, r]
        for b in range(d.n_hess[k]):
            qb = q[d.idx[k, b]]
            for r in range(3):
                ca[r] += qb * d.he[k, a, b, r]
        for r in range(3):
            dp[i, r] += A[li, r, 0] * ca[0] + A[li, r, 1] * ca[1] + A[li, r, 2] * ca[2]


@njit(cache=True)
def marker_frame(k, q, A, dA, d, R, dR):
    """R (3, 3) = the rotation of marker k's frame in ground, dR (n, 3, 3) dR/dq."""
    li = d.link[k]
    loc = d.R0[k].copy()
    for a in range(d.n_modes[k]):
        loc += q[d.idx[k, a]] * d.dR[k, a]
    for r in range(3):  # loops: the 3x3 blocks of A and dA are not contiguous
        for c in range(3):
            R[r, c] = A[li, r, 0] * loc[0, c] + A[li, r, 1] * loc[1, c] + A[li, r, 2] * loc[2, c]
            for i in range(q.shape[0]):
                dR[i, r, c] = dA[li, i, r, 0] * loc[0, c] + dA[li, i, r, 1] * loc[1, c] \
                    + dA[li, i, r, 2] * loc[2, c]
            for a in range(d.n_modes[k]):
                dR[d.idx[k, a], r, c] += A[li, r, 0] * d.dR[k, a, 0, c] \
                    + A[li, r, 1] * d.dR[k, a, 1, c] + A[li, r, 2] * d.dR[k, a, 2, c]


@njit(cache=True)
def frame_twist(R, dR, w):
    """w (n, 3): the frame's angular velocity per unit rate of each coordinate, ground
    axes, from [w_i]x = dR_i R^T (its antisymmetric part: the small-rotation rate of a
    flexible frame, whose R is orthogonal only to first order)."""
    for i in range(dR.shape[0]):
        Om = dR[i] @ R.T
        w[i, 0] = 0.5 * (Om[2, 1] - Om[1, 2])
        w[i, 1] = 0.5 * (Om[0, 2] - Om[2, 0])
        w[i, 2] = 0.5 * (Om[1, 0] - Om[0, 1])


@njit(cache=True)
def line_geometry(ka, kb, q, A, dA, d):
    """(length l (m), dl/dq (n,)) of the line from marker point ka to marker point kb."""
    n = q.shape[0]
    pa, pb = np.zeros(3), np.zeros(3)
    da, db = np.zeros((n, 3)), np.zeros((n, 3))
    marker_point(ka, q, A, dA, d, pa, da)
    marker_point(kb, q, A, dA, d, pb, db)
    x0, x1, x2 = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
    length = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    u0, u1, u2 = x0 / length, x1 / length, x2 / length
    dl = np.empty(n)
    for i in range(n):  # written out: no (n, 3) temporary
        dl[i] = (db[i, 0] - da[i, 0]) * u0 + (db[i, 1] - da[i, 1]) * u1 \
            + (db[i, 2] - da[i, 2]) * u2
    return length, dl


@njit(cache=True)
def load_row(row, link, p, F, T):
    """row (10,) = one physical load: its link's index, the point p (3,) m, the force F (3,)
    N and the torque T (3,) N m, ground axes (read back by
    :meth:`pipeline.dynamics.forces.compiled.CompiledForces.element_loads`)."""
    row[0] = link
    row[1:4] = p
    row[4:7] = F
    row[7:10] = T


@njit(cache=True)
def line_loads(ka, kb, f, q, A, dA, d, rows):
    """rows[:2] = the loads of a push f (N, > 0 drives the markers apart) along the line
    from marker point ka to kb: -f u at a, f u at b (u the unit vector a -> b). Returns 2."""
    n = q.shape[0]
    pa, pb = np.zeros(3), np.zeros(3)
    marker_point(ka, q, A, dA, d, pa, np.zeros((n, 3)))
    marker_point(kb, q, A, dA, d, pb, np.zeros((n, 3)))
    u = (pb - pa) / np.sqrt(np.sum((pb - pa) ** 2))
    load_row(rows[0], d.link[ka], pa, -f * u, np.zeros(3))
    load_row(rows[1], d.link[kb], pb, f * u, np.zeros(3))
    return 2


@njit(cache=True)
def no_potential(e, q, A, dA, d):
    """The potential of an element without a conservative part: 0 J."""
    return 0.0
