"""Rigid point bodies (payload, lumped equipment) attached to an FE model.

A point body of mass m and inertia J (about its own centre) at position p
moves with a 6-DOF rigid motion [t; theta] = G u read off the model's DOFs:

* solid models: least-squares rigid fit of the nodes around p
  (:func:`~pipeline.fem.rigid_fit.rigid_fit_operator`), either the nodes within
  ``attach_radius`` or the nearest nodes, at least 4 and not coplanar;
* beam models (6 DOF per node): the nearest node carries p rigidly
  (:func:`~pipeline.fem.rigid_fit.node_offset_operator`).

Its kinetic energy adds G^T diag(m 1, J) G to the mass matrix, and
``extras["point_masses"]`` records what :func:`~pipeline.fem.moments.mass_moments`
needs to add its C, C'_a, C''_ab.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_positive, validate_array
from pipeline.fem.model import FemModel
from pipeline.fem.rigid_fit import node_offset_operator, rigid_fit_operator, warn_if_far


@dataclass(frozen=True)
class PointMass:
    """A rigid point body.

    Parameters
    ----------
    name : str
        Name used in messages.
    position : (3,) array
        Centre of mass in the link frame, m.
    mass : float
        Mass, kg (> 0).
    inertia : (3, 3) array or None
        Inertia tensor about the centre of mass, kg m^2 (symmetric, positive
        semi-definite, satisfying the triangle inequalities); None for a
        particle.
    attach_radius : float or None
        Solids only: fit the rigid motion over every node within this radius,
        m; None: the nearest nodes (at least 4, not coplanar).
    """

    name: str
    position: np.ndarray
    mass: float
    inertia: np.ndarray | None = None
    attach_radius: float | None = None


def add_point_masses(model: FemModel, masses, where: str) -> FemModel:
    """A new model with the point bodies' mass added.

    Parameters
    ----------
    model : FemModel
        Solid (node_dofs (n, 3)) or beam (node_dofs (n, 6)) model.
    masses : iterable of PointMass
        Bodies to attach.
    where : str
        Owner named in messages, e.g. ``"link 'boom'"``.

    Returns
    -------
    FemModel
        Same stiffness; mass + sum G^T diag(m 1, J) G; ``extras["point_masses"]``
        extended by one dict per body with ``name``, ``mass`` (kg),
        ``second_moment`` S = tr(J)/2 1 - J (kg m^2), ``position`` (3,) m and
        ``operator`` G (6, n_dof) CSR.

    Raises
    ------
    ConfigError
        Non-positive mass, bad inertia, bad radius or too few nodes to attach.

    Examples
    --------
    >>> from pipeline.fem.model import FemModel
    >>> beam = FemModel("b", "beam", np.zeros((1, 3)), np.arange(6)[None],
    ...                 sp.csr_matrix((6, 6)), sp.csr_matrix((6, 6)))
    >>> out = add_point_masses(beam, [PointMass("tip", np.array([1.0, 0, 0]), 2.0)], "link 'b'")
    >>> float(out.mass.toarray()[5, 5])   # m d^2 about z for an offset d = 1 m
    2.0
    """
    added = []
    M = model.mass.copy()
    for pm in masses:
        label = f"{where}: point mass {pm.name!r}"
        m, J, p = _checked(pm, label)
        G = _attachment(model, p, pm.attach_radius, label)
        inertia = sp.block_diag([m * sp.identity(3), sp.csr_matrix(J)], format="csr")
        M = M + (G.T @ inertia @ G)
        added.append({"name": pm.name, "mass": m, "second_moment": 0.5 * np.trace(J) * np.eye(3) - J,
                      "position": p, "operator": G})
    M = (0.5 * (M + M.T)).tocsr()
    extras = dict(model.extras)
    extras["point_masses"] = tuple(model.extras.get("point_masses", ())) + tuple(added)
    return replace(model, mass=M, extras=extras)


def _checked(pm: PointMass, label: str) -> tuple[float, np.ndarray, np.ndarray]:
    """Validated (mass kg, inertia (3, 3) kg m^2, position (3,) m)."""
    m = check_positive(pm.mass, f"{label}: mass")
    p = validate_array(pm.position, (3,), f"{label}: position")
    if pm.inertia is None:
        return m, np.zeros((3, 3)), p
    J = validate_array(pm.inertia, (3, 3), f"{label}: inertia")
    scale = max(np.abs(J).max(), 1e-300)
    if np.abs(J - J.T).max() > 1e-9 * scale:
        raise ConfigError(f"{label}: inertia: expected a symmetric (3, 3) tensor, got {J.tolist()}")
    J = 0.5 * (J + J.T)
    principal = np.linalg.eigvalsh(J)
    # A real body's principal moments are >= 0 and obey I1 + I2 >= I3,
    # i.e. its second moment S = tr(J)/2 1 - J is positive semi-definite.
    if principal.min() < -1e-9 * scale or principal[2] > principal[0] + principal[1] + 1e-9 * scale:
        raise ConfigError(f"{label}: inertia: expected a positive semi-definite tensor with "
                          f"I1 + I2 >= I3, got principal moments {principal.tolist()}")
    return m, J, p


def _attachment(model: FemModel, p: np.ndarray, radius: float | None,
                label: str) -> sp.csr_matrix:
    """(6, n_dof) operator of the rigid motion of point p."""
    dist = np.linalg.norm(model.nodes - p, axis=1)
    warn_if_far(model.nodes, dist, p, label)
    if model.has_rotations:
        n = int(np.argmin(dist))
        return node_offset_operator(model.nodes[n], model.node_dofs[n], model.n_dof, p)
    if radius is not None:
        r = check_positive(radius, f"{label}: attach_radius")
        chosen = np.flatnonzero(dist <= r)
        if chosen.size < 4 or not _spans_volume(model.nodes[chosen]):
            raise ConfigError(f"{label}: attach_radius: expected a radius enclosing at least 4 "
                              f"non-coplanar nodes, got {r} m ({chosen.size} nodes)")
    else:
        chosen = _nearest_spanning(model.nodes, dist, label)
    return rigid_fit_operator(model.nodes[chosen], model.node_dofs[chosen], model.n_dof, p)


def _nearest_spanning(nodes: np.ndarray, dist: np.ndarray, label: str) -> np.ndarray:
    """The nearest nodes, growing from 4 until they are not coplanar."""
    order = np.argsort(dist, kind="stable")
    for k in range(4, order.size + 1):
        if _spans_volume(nodes[order[:k]]):
            return order[:k]
    raise ConfigError(f"{label}: expected a model with at least 4 non-coplanar nodes")


def _spans_volume(x: np.ndarray) -> bool:
    centred = x - x.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    return s.size == 3 and s[2] > 1e-8 * s[0]
