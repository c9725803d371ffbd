"""Geometric stiffening of a flexible link by its own spin, as a force element.

The link's reduced artifact holds the geometric stiffness of its modes under its own
centrifugal load (:mod:`pipeline.invariants.stiffening`): G (3, 3, m, m) with
K_G(w) = sum_ij w_i w_j G_ij for the body angular velocity w. In motion,

    Q_eta = -(sum_ij w_i w_j G_ij) eta:

the stiffening the linear modal kinematics miss (the centrifugal softening is already in
the mass invariants). Forces at the link's frames -- applied by force elements or
transmitted by joints, such as the axial force of a connecting rod between two pins --
are not this element's business: they stiffen the modes through the frames'
second-order translations (``Frame.hess``), conservatively; nor are the link's own
translational acceleration and gravity, which do it through its second-order first
moment of mass (``BodyMass.first_moment_hessian``). (The consistent Lagrangian
term for the spin, the inertia of the foreshortened link, would add O(eta^2) terms to
the mass matrix and the velocity terms, left out as in the usual linear
stress-stiffening formulations.)

Two choices keep it honest. The spin w is the link's rigid angular velocity -- from the
joint rates only, not from the elastic rotation rates of the links it hangs on, whose
fast oscillation would pump energy into the modes through w^2 (seen on the double
pendulum: rates of 100+ rad/s within 1.7 s). And its work is not booked as exchanged:
the force has no potential, so whatever work it does shows in the run's energy check as
error, which bounds the approximation (a run where it matters says "suspect").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.forces.base import ForceElement


@dataclass(frozen=True, eq=False)
class GeometricStiffening(ForceElement):
    """Geometric stiffening of link ``link`` by its own spin.

    Attributes
    ----------
    name : element name.
    link : the flexible link.
    stiffness : (3, 3, m, m) G of the link's kept modes, K_G(w) = sum_ij w_i w_j G_ij
        (:func:`pipeline.fem.geometric.centrifugal_tensor`), N m s^2 per modal unit^2.
    """

    name: str
    link: str
    stiffness: np.ndarray

    # not booked as exchanged work: its work is counted as energy error (module doc)
    conservative: ClassVar[bool] = True

    def validate(self, system) -> None:
        mech = system.mechanism
        idx = mech.modal_index[mech.link_index(self.link)]
        K = np.asarray(self.stiffness)
        if K.shape != (3, 3, idx.size, idx.size):
            raise ConfigError(f"force element '{self.name}': stiffness: expected shape "
                              f"(3, 3, {idx.size}, {idx.size}) for the kept modes of link "
                              f"{self.link!r}, got {K.shape}")

    def stiffness_at(self, omega: np.ndarray) -> np.ndarray:
        """(m, m) K_G(w) for the body angular velocity w (3,) rad/s, body axes."""
        return np.einsum("i,j,ijab->ab", omega, omega, self.stiffness)

    def _force(self, system, tree, q, qd, t):
        mech = system.mechanism
        li = mech.link_index(self.link)
        idx = mech.modal_index[li]
        R = tree.A[li][:3, :3]
        rigid = np.array(qd, dtype=float)
        for modal in mech.modal_index:
            rigid[modal] = 0.0  # the rigid spin, not the elastic rotation rates
        W = R.T @ np.einsum("k,kij->ij", rigid, tree.dA[li][:, :3, :3])  # [w]x, body axes
        omega = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])
        Q = np.zeros_like(q)
        Q[idx] = -self.stiffness_at(omega) @ q[idx]
        return Q

    def loads(self, system, tree, q, qd, t):
        return ()  # internal to the link: no load crosses a joint
