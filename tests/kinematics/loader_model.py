"""The front-end loader of ``loader_geometry.py`` as a 3-D Sheth-Uicker mechanism.

Every link's body frame sits at its first point of ``LINK_POINTS`` with the
revolute orientation (x forward, y up, z = chassis -y), so in the reference
configuration (arm lowered, cylinders at their reference lengths) every
revolute variable is 0, the chassis slide is 0 and the cylinder variables are
the pin-to-pin lengths. Cylinder frames: z from the base pin to the rod pin,
on the barrel at the base pin and on the rod at the rod pin.
"""

from __future__ import annotations

import loader_geometry as geo
import numpy as np

from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.rotations import frame_from_z, homogeneous

#: Revolute frame axes in chassis axes: x = x, y = z (up), z = -y.
R_REV = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def point3(name: str) -> np.ndarray:
    x, z = geo.POINTS[name]
    return np.array([x, 0.0, z])


def _link_frames(link: str, extra: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Frames (4, 4) in the body frame: every point (revolute orientation) plus ``extra``
    (global poses at the reference)."""
    pts = geo.LINK_POINTS[link]
    body = homogeneous(R_REV, point3(pts[0]))
    inv = np.linalg.inv(body)
    frames = {p: inv @ homogeneous(R_REV, point3(p)) for p in pts[1:]}
    frames.update({k: inv @ v for k, v in extra.items()})
    return frames


def _cyl_pose(cyl: geo.Cylinder, at: str) -> np.ndarray:
    return frame_from_z(point3(at), point3(cyl.rod_end) - point3(cyl.base), (0.0, -1.0, 0.0))


def build_loader():
    """(mechanism, reference q) of the loader; drive ``LCYL.d`` and ``TCYL.d``."""
    lift, tilt = geo.CYLINDERS["lift"], geo.CYLINDERS["tilt"]
    rail = frame_from_z(point3("REAR_AXLE"), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    extra = {
        "chassis": {"CHASSIS_X": rail},
        "lift_barrel": {"LCYL": _cyl_pose(lift, lift.base)},
        "lift_rod": {"LCYL": _cyl_pose(lift, lift.rod_end)},
        "tilt_barrel": {"TCYL": _cyl_pose(tilt, tilt.base)},
        "tilt_rod": {"TCYL": _cyl_pose(tilt, tilt.rod_end)},
    }
    links = [rigid_link("ground", {"CHASSIS_X": rail})]
    links += [rigid_link(name, _link_frames(name, extra.get(name, {})))
              for name in geo.LINK_POINTS]
    q0 = {"LCYL": geo.REFERENCE_LIFT_LENGTH, "TCYL": geo.REFERENCE_TILT_LENGTH}
    joints = []
    for j in geo.JOINTS:
        if j.type == "prismatic":
            pf = cf = j.name
        else:
            pf = j.point if j.point != geo.LINK_POINTS.get(j.parent, ("",))[0] else "body"
            cf = j.point if j.point != geo.LINK_POINTS[j.child][0] else "body"
        joints.append(Joint(j.name, j.type, j.parent, pf, j.child, cf, (q0.get(j.name, 0.0),)))
    mech = build_mechanism(links, joints)
    return mech, mech.q_initial.copy()
