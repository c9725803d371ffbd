"""Centrifugal geometric stiffening of a flexible link as a force element.

The link's reduced artifact holds K_G,c (6, m, m), the geometric stiffness of its modes
under the unit centrifugal load cases (:mod:`pipeline.invariants.stiffening`). In
motion, with w the link's body angular velocity (body axes),

    Q_eta = -K_G(w) eta,    K_G(w) = sum_c p_c(w) K_G,c,

the stiffening that the linear modal kinematics miss (a spinning blade, a slewing boom).
The force depends on the rates, so it is booked as non-conservative: its power
``Q . qd`` enters the run's energy balance as work exchanged, and the balance stays
exact. (The consistent Lagrangian term would add O(eta^2) gyroscopic corrections,
left out as in the usual linear stress-stiffening formulations.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.forces.base import ForceElement

#: products w_i w_j in the order of the stored cases (pipeline.fem.geometric)
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@dataclass(frozen=True, eq=False)
class CentrifugalStiffening(ForceElement):
    """Geometric stiffening of link ``link`` by its own spin.

    Attributes
    ----------
    name : element name.
    link : the flexible link.
    stiffness : (6, m, m) K_G,c of the link's kept modes, N m s^2 per modal unit^2.
    """

    name: str
    link: str
    stiffness: np.ndarray

    conservative: ClassVar[bool] = False

    def validate(self, system) -> None:
        mech = system.mechanism
        idx = mech.modal_index[mech.link_index(self.link)]
        K = np.asarray(self.stiffness)
        if K.shape != (6, idx.size, idx.size):
            raise ConfigError(f"force element '{self.name}': stiffness: expected shape "
                              f"(6, {idx.size}, {idx.size}) for the kept modes of link "
                              f"{self.link!r}, got {K.shape}")

    def stiffness_at(self, omega: np.ndarray) -> np.ndarray:
        """(m, m) K_G(w) for the body angular velocity w (3,) rad/s, body axes."""
        p = np.array([omega[i] * omega[j] for i, j in _PAIRS])
        return np.einsum("c,cab->ab", p, self.stiffness)

    def _force(self, system, tree, q, qd, t):
        mech = system.mechanism
        li = mech.link_index(self.link)
        idx = mech.modal_index[li]
        R = tree.A[li][:3, :3]
        W = R.T @ np.einsum("k,kij->ij", qd, tree.dA[li][:, :3, :3])  # [w]x, body axes
        omega = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])
        Q = np.zeros_like(q)
        Q[idx] = -self.stiffness_at(omega) @ q[idx]
        return Q

    def loads(self, system, tree, q, qd, t):
        return ()  # internal to the link: no load crosses a joint
