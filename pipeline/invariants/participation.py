"""Modal participation and effective mass of a reduced link, and a deterministic basis
for repeated frequencies.

Both come from the mass invariants alone. With C'_a = int rho r phi_a^T dV (DESIGN §2;
row 3 of the homogeneous r is 1), the participation of mode a in the rigid motions of a
frame at point p with axes R (columns) is

    translation  L_t = R^T int rho phi_a dV                   = R^T C'_a[3, :3]
    rotation     L_r = R^T int rho (r - p) x phi_a dV

and its effective mass L^2 / m_a (m_a the modal mass). Summed over every mode of a model
clamped at the reference, the translational effective masses tend to the link's mass
(less what sits on the clamped interface), the rotational ones to its inertia about p.

A link with a symmetric section (Iy = Iz) has pairs of equal frequencies whose modes the
eigen solver returns as arbitrary mixtures of the two bending planes. :func:`align_repeated`
rotates each cluster of (nearly) equal frequencies so that its modes move along the body
axes one after the other, which makes plane filters and mode counts mean the same on every
mesh.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pipeline.invariants.reduced_link import FrameModes, ReducedLink
from pipeline.modes.basis import sign_flips
from pipeline.modes.clamped import REPEATED_RTOL

#: the six rigid directions of a frame, in the order of the participation columns
DIRECTIONS = ("tx", "ty", "tz", "rx", "ry", "rz")


def participation(link: ReducedLink, frame: str | None = None) -> np.ndarray:
    """(m, 6) participation factors of the modes in the rigid motions of ``frame`` (default:
    the body frame), along and about its axes: kg m per modal unit (translations) and
    kg m^2 (rotations), for the link's mode normalisation."""
    pose = np.eye(4) if frame is None else link.frame(frame).pose
    R, p = pose[:3, :3], pose[:3, 3]
    Cp = np.asarray(link.Cp)
    t = Cp[:, 3, :3]  # int rho phi
    rxphi = np.stack([Cp[:, 1, 2] - Cp[:, 2, 1], Cp[:, 2, 0] - Cp[:, 0, 2],
                      Cp[:, 0, 1] - Cp[:, 1, 0]], axis=1)  # int rho r x phi
    rot = rxphi - np.cross(p, t)
    return np.hstack([t @ R, rot @ R])


def rigid_totals(link: ReducedLink, frame: str | None = None) -> np.ndarray:
    """(6,) the link's mass (kg, three times) and its moments of inertia about the axes of
    ``frame`` through its origin (kg m^2): what the effective masses are fractions of."""
    pose = np.eye(4) if frame is None else link.frame(frame).pose
    R, p = pose[:3, :3], pose[:3, 3]
    C = np.asarray(link.C)
    m, c1 = C[3, 3], C[:3, 3]
    S = C[:3, :3] - np.outer(p, c1) - np.outer(c1, p) + m * np.outer(p, p)
    J = R.T @ (np.trace(S) * np.eye(3) - S) @ R
    return np.r_[m, m, m, np.diag(J)]


def effective_mass(link: ReducedLink, frame: str | None = None) -> np.ndarray:
    """(m, 6) effective mass of each mode in each rigid direction of ``frame`` (kg, and
    kg m^2 for the rotations): L^2 / m_a."""
    L = participation(link, frame)
    return L ** 2 / np.diag(link.modal_mass)[:, None]


def effective_mass_fractions(link: ReducedLink, frame: str | None = None) -> np.ndarray:
    """(m, 6) :func:`effective_mass` over :func:`rigid_totals` (0 where a total is 0).

    Examples
    --------
    A cantilever's first bending mode carries 61 % of its mass, the first three 90 %
    (Euler-Bernoulli: 0.613, 0.188, 0.065); see ``tests/invariants/test_participation.py``.
    """
    tot = rigid_totals(link, frame)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(tot > 0, effective_mass(link, frame) / tot, 0.0)


def repeated_clusters(frequencies_hz: np.ndarray, kinds, rtol: float = REPEATED_RTOL) -> list[list[int]]:
    """Groups of consecutive modes of one kind whose frequencies agree within ``rtol``.

    Examples
    --------
    >>> repeated_clusters(np.array([10.0, 10.001, 25.0, 40.0, 40.0]), ["normal"] * 5)
    [[0, 1], [3, 4]]
    """
    out, group = [], [0] if len(frequencies_hz) else []
    for a in range(1, len(frequencies_hz)):
        f0, f1 = frequencies_hz[group[-1]], frequencies_hz[a]
        if kinds[a] == kinds[group[-1]] and abs(f1 - f0) <= rtol * max(abs(f1), 1e-300):
            group.append(a)
        else:
            out.append(group)
            group = [a]
    if group:
        out.append(group)
    return [g for g in out if len(g) > 1]


def align_repeated(link: ReducedLink, rtol: float = REPEATED_RTOL) -> ReducedLink:
    """The link with each cluster of repeated frequencies (:func:`repeated_clusters`)
    rotated so that its modes move along the body axes in turn: the first mode of a
    cluster carries all of the cluster's motion along the axis where it has the most,
    the next the most of what is left, and so on (an orthogonal change of basis inside
    the cluster: the subspace, and so the dynamics, is unchanged). Frequencies become the
    Rayleigh quotients of the new modes. A link without repeated frequencies is returned
    as it is.
    """
    clusters = repeated_clusters(np.asarray(link.frequencies_hz), link.mode_kinds, rtol)
    if not clusters:
        return link
    m = link.n_modes
    Q = np.eye(m)
    shapes = np.asarray(link.mode_shapes)  # (m, N, 3)
    for g in clusters:
        Q[np.ix_(g, g)] = _axis_aligned(shapes[g])
    return transform_modes(link, Q, {"aligned_clusters": clusters})


def _axis_aligned(S: np.ndarray) -> np.ndarray:
    """(k, k) orthogonal Q: new mode j = sum_i Q[i, j] old mode i, greedy along the axes."""
    k = S.shape[0]
    basis = np.eye(k)  # columns span what is left of the cluster
    cols = []
    for _ in range(k):
        # content of each axis in the remaining space: G_d = B^T S_d S_d^T B
        G = [basis.T @ S[:, :, d] @ S[:, :, d].T @ basis for d in range(3)]
        tr = np.array([np.trace(x) for x in G])
        d = int(np.argmax(tr >= (1 - 1e-6) * tr.max()))  # ties: the first axis, every mesh
        _, v = np.linalg.eigh(G[d])
        c = basis @ v[:, -1]
        cols.append(c)
        # deflate: the remaining space is orthogonal to the chosen combination
        rest = basis - np.outer(c, c @ basis)
        u = np.linalg.svd(rest, full_matrices=False)[0]
        basis = u[:, : basis.shape[1] - 1]
    return np.array(cols).T


def transform_modes(link: ReducedLink, Q: np.ndarray, note: dict | None = None) -> ReducedLink:
    """The link in the modes phi'_a = sum_b Q[b, a] phi_b (Q (m, m) orthogonal): every
    modal invariant transformed, signs fixed so each mode's largest nodal displacement is
    positive, frequencies the Rayleigh quotients."""
    Q = np.asarray(Q, dtype=float)
    shapes = np.einsum("ba,bnk->ank", Q, link.mode_shapes)
    s = sign_flips(shapes.reshape(shapes.shape[0], -1).T)
    Q = Q * s
    shapes = shapes * s[:, None, None]
    K = Q.T @ link.modal_stiffness @ Q
    M = Q.T @ link.modal_mass @ Q
    freq = np.sqrt(np.maximum(np.diag(K) / np.diag(M), 0.0)) / (2 * np.pi)
    frames = tuple(FrameModes(f.name, f.pose, Q.T @ f.phi, Q.T @ f.psi, f.kind)
                   for f in link.frames)
    KG, KF, S = link.geometric_stiffness, link.force_geometric_stiffness, link.stress_modes
    KI = link.inertia_geometric_stiffness
    meta = dict(link.meta)
    if note:
        meta["modal_basis"] = {**dict(meta.get("modal_basis", {})), **note}
    return replace(
        link, Cp=np.einsum("ba,bij->aij", Q, link.Cp),
        Cpp=np.einsum("ba,dc,bdij->acij", Q, Q, link.Cpp, optimize=True),
        modal_stiffness=0.5 * (K + K.T), modal_mass=0.5 * (M + M.T), frequencies_hz=freq,
        frames=frames, mode_shapes=shapes, meta=meta,
        geometric_stiffness=np.einsum("ba,cbd,de->cae", Q, KG, Q) if KG.size else KG,
        force_geometric_stiffness=np.einsum("ba,fkbd,de->fkae", Q, KF, Q) if KF.size else KF,
        inertia_geometric_stiffness=(np.einsum("ba,jkbd,de->jkae", Q, KI, Q) if KI.size
                                     else KI),
        stress_modes=np.einsum("ba,bnk->ank", Q, S).astype(np.float32) if S.size else S)
