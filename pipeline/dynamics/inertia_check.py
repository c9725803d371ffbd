"""Does a machine have inertia for every motion its joints allow?

Rigid links may carry inertias no single body has -- a thin rod without a moment about its
axis, a flywheel's reflected drivetrain inertia about one axis -- and that is right as long
as the joints never turn the link about the axis that lacks it. What is wrong is a motion
the joints allow with no kinetic energy: the mass matrix reduced to the independent
velocities, B^T M B (B = dq/dx with the drivers held), is then singular and no integrator
can say how the machine moves. :func:`motion_without_inertia` finds such a motion.
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics.mass_matrix import mass_matrix
from pipeline.dynamics.statics import reduced_coordinates, velocity_transform
from pipeline.kinematics import evaluate_tree

__all__ = ["INERTIA_RTOL", "motion_without_inertia"]

#: a reduced mass matrix whose smallest eigenvalue is below this share of its largest is
#: singular
INERTIA_RTOL = 1e-12


def motion_without_inertia(system, q: np.ndarray) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(coordinates, links) of a motion the joints allow at q (n,) without kinetic energy,
    drivers held: the coordinates that move in it and the links that move; ((), ()) if
    every allowed motion has inertia.

    The reduced mass matrix B^T M B in the independent coordinates, each column scaled by
    its coordinate's natural unit (radians, the length scale, a modal amplitude that moves
    a frame by it), is singular below :data:`INERTIA_RTOL` of its largest eigenvalue.
    """
    mech = system.mechanism
    q, red = reduced_coordinates(system, np.asarray(q, dtype=float))
    if not red.x.size:
        return (), ()
    B = velocity_transform(system, q, red) * mech.coordinate_units[red.x]
    tree = evaluate_tree(mech, q)
    Mr = B.T @ mass_matrix(system, tree, q) @ B
    lam, V = np.linalg.eigh(0.5 * (Mr + Mr.T))
    if lam[-1] <= 0 or lam[0] > INERTIA_RTOL * lam[-1]:
        return (), ()
    qd = B @ V[:, 0]
    coords = tuple(mech.coordinates[i] for i in np.flatnonzero(np.abs(qd) > 1e-6 *
                                                               np.abs(qd).max()))
    moving = []
    for li, link in enumerate(mech.links):
        W = np.einsum("nij,n->ij", tree.dA[li], qd)
        if np.abs(W).max() > 1e-6 * np.abs(qd).max() * max(1.0, float(mech.length_scale)):
            moving.append(link.name)
    return coords, tuple(moving)
