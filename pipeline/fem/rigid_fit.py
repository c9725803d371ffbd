"""Operators that read a 6-DOF rigid motion (translation, small rotation) of a
reference point off an FE displacement vector.

Used for RBE3-like (averaging) interfaces, for markers, for point masses
spread over a cluster of nodes and for checking interface rotations. Both
return a sparse (6, n_dof) matrix ``G`` with ``[t; theta] = G @ u``: ``t`` is
the translation of the reference point (m) and ``theta`` the small rotation
vector (rad), in the model's frame.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import ConfigError

logger = logging.getLogger(__name__)

#: a point farther than this fraction of its model's size from every node is said to be:
#: allowed (a lug or a payload that is not meshed), but a typo (5 for 0.5) would otherwise
#: be extrapolated silently
FAR_FROM_MESH = 0.25


def warn_if_far(nodes: np.ndarray, dist: np.ndarray, point, where: str) -> None:
    """Log a warning if ``point`` (3,) m, at distances ``dist`` (n,) m from the ``nodes``
    (n, 3), lies farther than :data:`FAR_FROM_MESH` times the model's size (largest side of
    the nodes' bounding box) from every node: its motion would be the nearest nodes' rigid
    fit carried out to it."""
    position = [float(x) for x in point]
    d = float(dist.min())
    size = float(np.ptp(nodes, axis=0).max())
    if size > 0 and d > FAR_FROM_MESH * size:  # (a single node has no size to compare)
        logger.warning("%s at %s is %.3g m from the nearest FE node, %.0f times the link's "
                       "size (%.3g m): its motion is the rigid fit of the nodes nearest it, "
                       "extrapolated; check its position", where, position, d, d / size, size)


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix [v]x of a 3-vector, so that skew(a) @ b = a x b."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rigid_fit_operator(
    coords: np.ndarray,
    dofs: np.ndarray,
    n_dof: int,
    point: np.ndarray,
    weights: np.ndarray | None = None,
) -> sp.csr_matrix:
    """Weighted least-squares rigid fit of nodal translations about ``point``.

    Minimises sum_i w_i |u_i - (t + theta x r_i)|^2 with r_i = x_i - point.

    Parameters
    ----------
    coords : (k, 3) node coordinates, m.
    dofs : (k, 3) global DOF numbers of (ux, uy, uz) of those nodes.
    n_dof : total number of DOFs of the model.
    point : (3,) reference point, m.
    weights : (k,) positive weights (default: equal).

    Returns
    -------
    G : (6, n_dof) CSR matrix.

    Raises
    ------
    ConfigError
        If the nodes cannot determine a rotation (fewer than 3 non-collinear).

    Examples
    --------
    >>> x = np.array([[1., 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    >>> G = rigid_fit_operator(x, np.arange(12).reshape(4, 3), 12, np.zeros(3))
    >>> u = np.cross([0, 0, 0.1], x).ravel()   # rotation 0.1 rad about z
    >>> np.round(G @ u, 12)
    array([0. , 0. , 0. , 0. , 0. , 0.1])
    """
    coords = np.asarray(coords, float)
    dofs = np.asarray(dofs, int)
    k = coords.shape[0]
    w = np.ones(k) if weights is None else np.asarray(weights, float)
    # fitted about the nodes' centroid, then carried to the point: the same rigid motion,
    # but the normal matrix stays as well conditioned as the nodes' spread, however far
    # the point (about the point itself, a lever of 60 m over centimetres lost rank)
    centre = w @ coords / w.sum()
    r = coords - centre
    A = np.zeros((k, 3, 6))
    A[:, :, :3] = np.eye(3)
    A[:, :, 3:] = -np.array([skew(ri) for ri in r])
    N = np.einsum("k,kai,kaj->ij", w, A, A)
    if np.linalg.matrix_rank(N, tol=1e-10 * max(np.abs(N).max(), 1e-300)) < 6:
        raise ConfigError(
            "rigid fit needs at least 3 non-collinear nodes; got a degenerate node set"
        )
    B = np.linalg.solve(N, (w[:, None, None] * A).transpose(2, 0, 1).reshape(6, 3 * k))
    B[:3] -= skew(np.asarray(point, float) - centre) @ B[3:]  # t_p = t_c + theta x (p - c)
    rows = np.repeat(np.arange(6), 3 * k)
    cols = np.tile(dofs.reshape(-1), 6)
    return sp.csr_matrix((B.ravel(), (rows, cols)), shape=(6, n_dof))


def node_offset_operator(
    node: np.ndarray, dofs6: np.ndarray, n_dof: int, point: np.ndarray
) -> sp.csr_matrix:
    """Rigid motion of ``point`` carried by one 6-DOF node (beam) at ``node``.

    t = u_n + theta_n x (point - node), theta = theta_n; returns (6, n_dof) CSR.
    """
    d = np.asarray(point, float) - np.asarray(node, float)
    B = np.zeros((6, 6))
    B[:3, :3] = np.eye(3)
    B[:3, 3:] = -skew(d)
    B[3:, 3:] = np.eye(3)
    rows = np.repeat(np.arange(6), 6)
    cols = np.tile(np.asarray(dofs6, int), 6)
    return sp.csr_matrix((B.ravel(), (rows, cols)), shape=(6, n_dof))
