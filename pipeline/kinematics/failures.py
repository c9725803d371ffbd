"""Kinematic failures that carry what the user needs to fix them.

Both are :class:`~pipeline.core.errors.KinematicsError` subclasses; their
attributes hold the numbers the message summarises.
"""

from __future__ import annotations

import numpy as np

from pipeline.core.errors import KinematicsError

__all__ = ["ClosureError", "SingularConfigurationError"]


class ClosureError(KinematicsError):
    """A loop cannot be closed.

    Attributes
    ----------
    loop : name of the loop with the largest remaining residual, e.g. "L2".
    cut_joint : name of that loop's cut joint.
    residual : (6 k,) closure residual at the closest configuration (m, rad).
    q_closest : (n,) closest configuration found (least-squares minimum).
    """

    def __init__(self, message: str, loop: str, cut_joint: str, residual: np.ndarray,
                 q_closest: np.ndarray):
        super().__init__(message)
        self.loop = loop
        self.cut_joint = cut_joint
        self.residual = residual
        self.q_closest = q_closest

    def __reduce__(self):  # pickles (errors cross process boundaries in parallel runs)
        return type(self), (str(self), self.loop, self.cut_joint, self.residual,
                            self.q_closest)


class SingularConfigurationError(KinematicsError):
    """The dependent coordinates cannot be solved for: the constraint Jacobian
    restricted to the non-prescribed coordinates loses rank.

    Attributes
    ----------
    joints : joints whose variables move in the lost (singular) direction.
    q : (n,) configuration where it happened.
    t : time (s) in a sweep, else None.
    drivers : {coordinate name: prescribed value} at that instant.
    rcond : smallest / largest singular value of the scaled block.
    """

    def __init__(self, message: str, joints: tuple[str, ...], q: np.ndarray,
                 t: float | None = None, drivers: dict[str, float] | None = None,
                 rcond: float = 0.0):
        super().__init__(message)
        self.joints = joints
        self.q = q
        self.t = t
        self.drivers = dict(drivers or {})
        self.rcond = rcond

    def __reduce__(self):
        return type(self), (str(self), self.joints, self.q, self.t, self.drivers,
                            self.rcond)
