"""Geometric stiffening of a flexible link as a force element.

The link's reduced artifact holds the geometric stiffness of its modes under unit load
cases (:mod:`pipeline.invariants.stiffening`): for its own centrifugal load, as G (3, 3,
m, m) with K_G(w) = sum_ij w_i w_j G_ij for the body angular velocity w, and K_F (F, 3,
m, m) for unit forces along the body axes at each of its frames. In motion,

    Q_eta = -(sum_ij w_i w_j G_ij + sum_f sum_k F_f,k K_F,f,k) eta,

with F_f the body-axes force that the other force elements apply at frame f (a point
force pulling a rod, a load hanging from a boom tip): the stiffening (or, in compression,
softening) that the linear modal kinematics miss. Forces that joints transmit (the axial
force of a connecting rod between two pins) are not included yet. The force depends on
the rates and on the other elements. (The consistent Lagrangian term, the inertia of the
foreshortened link, would add O(eta^2) terms to the mass matrix and the velocity terms,
left out as in the usual linear stress-stiffening formulations.)

Two choices keep it honest. The spin w is the link's rigid angular velocity -- from the
joint rates only, not from the elastic rotation rates of the links it hangs on, whose
fast oscillation would pump energy into the modes through w^2 (seen on the double
pendulum: rates of 100+ rad/s within 1.7 s). And its work is not booked as exchanged:
the force has no potential, so whatever work it does shows in the run's energy check as
error, which bounds the approximation (a run where it matters says "suspect").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.forces.base import ForceElement, marker_pose


@dataclass(frozen=True, eq=False)
class GeometricStiffening(ForceElement):
    """Geometric stiffening of link ``link`` by its own spin and by the forces other
    elements apply at its frames.

    Attributes
    ----------
    name : element name.
    link : the flexible link.
    stiffness : (3, 3, m, m) G of the link's kept modes, K_G(w) = sum_ij w_i w_j G_ij
        (:func:`pipeline.fem.geometric.centrifugal_tensor`), N m s^2 per modal unit^2.
    frames : names of the frames ``frame_stiffness`` refers to.
    frame_stiffness : (F, 3, m, m) K_F per unit body-axes force at each frame, m per
        modal unit^2 (empty: no force stiffening).
    """

    name: str
    link: str
    stiffness: np.ndarray
    frames: tuple = ()
    frame_stiffness: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 0, 0)))

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
        KF = np.asarray(self.frame_stiffness)
        if KF.size and KF.shape != (len(self.frames), 3, idx.size, idx.size):
            raise ConfigError(f"force element '{self.name}': frame_stiffness: expected shape "
                              f"({len(self.frames)}, 3, {idx.size}, {idx.size}), got {KF.shape}")

    def stiffness_at(self, omega: np.ndarray) -> np.ndarray:
        """(m, m) K_G(w) for the body angular velocity w (3,) rad/s, body axes."""
        return np.einsum("i,j,ijab->ab", omega, omega, self.stiffness)

    def frame_forces(self, system, tree, q, qd, t) -> np.ndarray:
        """(F, 3) body-axes force (N) the other force elements apply at each frame; a load
        whose point is not at one of the frames (within 1e-6 m) is not counted."""
        out = np.zeros((len(self.frames), 3))
        if not np.size(self.frame_stiffness):
            return out
        loads = []
        for element in system.forces:
            if isinstance(element, GeometricStiffening):
                continue
            try:
                loads += [x for x in element.loads(system, tree, q, qd, t)
                          if x.link == self.link]
            except NotImplementedError:
                continue
        if not loads:  # the frames' poses only when something acts on the link
            return out
        R = tree.A[system.mechanism.link_index(self.link)][:3, :3]
        where = np.array([marker_pose(system, self.link, f, tree, q)[:3, 3]
                          for f in self.frames])
        for load in loads:
            d = np.linalg.norm(where - load.point, axis=1)
            f = int(np.argmin(d))
            if d[f] <= 1e-6:
                out[f] += R.T @ load.force
        return out

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
        K = self.stiffness_at(omega)
        if np.size(self.frame_stiffness):
            F = self.frame_forces(system, tree, q, qd, t)
            K = K + np.einsum("fk,fkab->ab", F, self.frame_stiffness)
        Q = np.zeros_like(q)
        Q[idx] = -K @ q[idx]
        return Q

    def loads(self, system, tree, q, qd, t):
        return ()  # internal to the link: no load crosses a joint
