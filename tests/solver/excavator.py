"""An excavator-type slewing base under a planar boom/cylinder loop.

Ground -> base (revolute about the vertical: the slew) -> boom (pinned to the base about the
base's y axis); a hydraulic cylinder (barrel pinned to the base, rod sliding in the barrel,
rod pinned to the boom) closes a loop in the base's x-z plane. Built in 3D, the loop's three
out-of-plane closure rows are redundant, and the slew moves the whole loop rigidly: its column
of the loop's Jacobian is zero but for round-off (it used to be normalised into a unit column
and refused as over-constraining).

``planar=True`` builds the same boom loop on the ground (no base, no slew): the reference for
the base held still. Pin frames have their z axis along the base's y (rot_x(-pi/2)); in them
the loop is planar in (x, -z_base).
"""

from __future__ import annotations

import numpy as np

from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import JointSpringDamper
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.rotations import homogeneous, rot_x, rot_y

PIN = rot_x(-np.pi / 2)  # z along the base's y axis
PIVOT, CYL = np.array([0.3, 0.0, 0.5]), np.array([0.6, 0.0, 0.1])
BOOM_PIN, BOOM_TIP = 1.0, 3.0
PHI0 = -0.3  # boom angle in the pin frames (negative raises it)
K_CYL, C_CYL = 2.0e6, 4.0e3  # N/m, N s/m: the cylinder's oil column


def _cylinder_geometry(phi):
    """(stroke length, barrel angle) for boom angle phi, in the pin plane."""
    p = np.array([PIVOT[0], -PIVOT[2]]) + BOOM_PIN * np.array([np.cos(phi), np.sin(phi)])
    c = np.array([CYL[0], -CYL[2]])
    d = p - c
    return float(np.linalg.norm(d)), float(np.arctan2(d[1], d[0]))


def build(planar: bool = False, slew: float = 0.7) -> tuple[System, np.ndarray]:
    """(system without drivers, assembled q0); the stroke carries a spring-damper whose free
    length is the initial stroke (so the boom hangs on it and sags under gravity)."""
    length, psi = _cylinder_geometry(PHI0)
    on = "ground" if planar else "base"
    base_frames = {"pivot": homogeneous(PIN, PIVOT), "cyl": homogeneous(PIN, CYL)}
    links = [rigid_link("ground", base_frames if planar else {})]
    bodies = {}
    if not planar:
        links.append(rigid_link("base", base_frames))
        bodies["base"] = BodyMass.rigid(500.0, [0.2, 0.0, 0.3], np.diag([60.0, 80.0, 90.0]))
    links += [rigid_link("boom", {"rod": homogeneous(np.eye(3), [BOOM_PIN, 0.0, 0.0])}),
              rigid_link("barrel", {"slide": homogeneous(rot_y(np.pi / 2))}),
              rigid_link("rod", {"slide": homogeneous(rot_y(np.pi / 2))})]
    bodies["boom"] = BodyMass.rigid(200.0, [1.5, 0.0, 0.0], np.diag([2.0, 150.0, 150.0]))
    bodies["barrel"] = BodyMass.rigid(20.0, [0.3, 0.0, 0.0], np.diag([0.05, 0.6, 0.6]))
    bodies["rod"] = BodyMass.rigid(15.0, [-0.2, 0.0, 0.0], np.diag([0.03, 0.3, 0.3]))
    joints = [] if planar else [Joint("slew", "revolute", "ground", "body", "base", "body",
                                      (slew,))]
    joints += [Joint("pivot", "revolute", on, "pivot", "boom", "body", (PHI0,)),
               Joint("cyl_pin", "revolute", on, "cyl", "barrel", "body", (psi,)),
               Joint("stroke", "prismatic", "barrel", "slide", "rod", "slide", (length,)),
               Joint("rod_pin", "revolute", "rod", "body", "boom", "rod", (PHI0 - psi,))]
    mech = build_mechanism(links, joints)
    spring = JointSpringDamper("oil", "stroke.d", stiffness=K_CYL, damping=C_CYL,
                               free_value=length)
    system = System(mech, bodies, gravity=[0.0, 0.0, -9.81], forces=(spring,))
    return system, mech.q_initial.copy()
