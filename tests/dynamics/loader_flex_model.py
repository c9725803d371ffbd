"""The front-end loader (tests/kinematics/loader_model.py) with two flexible links:
the lift arm reduced from ``meshes/lift_arm.yaml`` (optionally coarsened) and the
lower lift link reduced from a plate_with_bores spec written here.

Both plates lie in the loader's side plane (plate x-y = revolute x-y, thickness
along the pin axes). Only their in-plane modes are kept: the planar loads do
not excite the out-of-plane ones, and the planar loops (closed in 3-D) would
tie them to the rigid links' redundant out-of-plane constraints.

Bodies: rigid links take the documented mass properties (loader_geometry.py),
the flexible ones the reduced invariants with 2 % modal damping. Drivers: lift
cylinder over its stroke by a quintic smooth step, tilt cylinder retracted
over the same time to keep the bucket near level (as in the kinetostatics
tests), chassis held. Load: the rated 4.4482 kN at the bucket's LOAD point.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
import loader_geometry as lg
from loader_model import R_REV, _cyl_pose, _link_frames, point3

from pipeline.dynamics import BodyMass, System, body_from_reduced
from pipeline.dynamics import in_plane_modes as dynamics_in_plane_modes
from pipeline.dynamics.forces import PointForce
from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
from pipeline.kinematics.drivers import Constant, SmoothStep
from pipeline.kinematics.links import link_from_frames
from pipeline.kinematics.rotations import frame_from_z, homogeneous, rot_z

ROOT = Path(__file__).resolve().parents[2]
ZETA = 0.02

LOWER_LINK = """\
name: lower_link
geometry:
  type: solid
  recipe: plate_with_bores
  params:
    length: {length}
    width: 0.07
    thickness: 0.025
    corner_radius: 0.03
    bores:
      - {{name: A, center: [0.04, 0.0], radius: 0.018}}
      - {{name: B, center: [{xb}, 0.0], radius: 0.018}}
  mesh_size: {size}
  order: 2
material: {{E: 2.1e11, nu: 0.3, rho: 7850}}
interfaces:
  - name: A
    selector: {{type: group, name: bore_A}}
    origin: [0.04, 0.0, 0.0]
  - name: B
    selector: {{type: group, name: bore_B}}
    origin: [{xb}, 0.0, 0.0]
reference: A
modes: {{count: {modes}}}
"""


def in_plane_modes(red, n: int, tol: float = 1e-3) -> list[int]:
    """Indices of the first n modes whose frames move in the x-y plane only
    (phi_z, psi_x, psi_y below tol x the in-plane motion)."""
    return list(dynamics_in_plane_modes(red, "xy", tol))[:n]


def reduce_links(folder: Path, arm_size: float = 0.02, link_size: float = 0.015,
                 arm_modes: int = 2, link_modes: int = 1):
    """Reduce the lift arm and the lower link in ``folder``; returns
    {name: (ReducedLink, kept mode indices)}."""
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    folder = Path(folder)
    text = (ROOT / "meshes" / "lift_arm.yaml").read_text()
    text = re.sub(r"mesh_size: [0-9.e-]+", f"mesh_size: {arm_size}", text)
    text = re.sub(r"count: \d+", "count: 10", text)
    (folder / "lift_arm.yaml").write_text(text)
    L = float(np.hypot(*np.subtract(lg.POINTS["LLAPT"], lg.POINTS["LCPT"])))
    (folder / "lower_link.yaml").write_text(LOWER_LINK.format(
        length=L + 0.08, xb=0.04 + L, size=link_size, modes=6))
    out = {}
    for name, n in (("lift_arm", arm_modes), ("lower_link", link_modes)):
        red = reduce_spec(load_link_spec(folder / f"{name}.yaml"), folder, folder / "links")[0]
        out[name] = (red, in_plane_modes(red, n))
    return out


@dataclass(frozen=True)
class _Frame:
    name: str
    pose: np.ndarray
    phi: np.ndarray
    psi: np.ndarray


def _planar(name, f, modes, local) -> _Frame:
    """Frame rotated by ``local`` (4, 4, a pure rotation about z) on reduced frame f,
    with the kept modes' motions projected on the plane: the mesh leaves
    |psi_x|, |psi_y|, |phi_z| ~ 1e-4 of the in-plane motion, which the planar loops
    (overconstrained in 3-D) could not follow."""
    phi, psi = np.array(f.phi[modes]), np.array(f.psi[modes])
    phi[:, 2] = 0.0
    psi[:, :2] = 0.0
    return _Frame(name, f.pose @ local, phi, psi)


def _flex_link(name, red, modes):
    """(kinematics Link, name of the proximal pin frame) with frames named like the
    loader's points, revolute axes."""
    if name == "lift_arm":  # spec in the loader's pin coordinates: frames = interfaces
        names = {"lower_link": "PIN", "upper_link": "ULAPT", "lift_cylinder": "ULCPT",
                 "tilt_cylinder": "UTCPT", "bucket": "BKPT"}
        local = np.eye(4)
    else:  # lower link: plate x from LCPT to LLAPT, at alpha from the revolute axes
        names = {"A": "PIN", "B": "LLAPT"}
        d = np.subtract(lg.POINTS["LLAPT"], lg.POINTS["LCPT"])
        local = homogeneous(rot_z(-np.arctan2(d[1], d[0])))
    frames = [_planar(names[f.name], f, modes, local) for f in red.frames]
    return link_from_frames(name, frames), "PIN"


def build_flexible_loader(reduced, t_lift: float = 10.0):
    """(System, q0) of the loader with the flexible links of ``reduced``
    (output of :func:`reduce_links`)."""
    lift, tilt = lg.CYLINDERS["lift"], lg.CYLINDERS["tilt"]
    rail = frame_from_z(point3("REAR_AXLE"), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    extra = {"chassis": {"CHASSIS_X": rail},
             "lift_barrel": {"LCYL": _cyl_pose(lift, lift.base)},
             "lift_rod": {"LCYL": _cyl_pose(lift, lift.rod_end)},
             "tilt_barrel": {"TCYL": _cyl_pose(tilt, tilt.base)},
             "tilt_rod": {"TCYL": _cyl_pose(tilt, tilt.rod_end)}}
    links, body_frame = [rigid_link("ground", {"CHASSIS_X": rail})], {}
    for name in lg.LINK_POINTS:
        if name in reduced:
            link, body_frame[name] = _flex_link(name, *reduced[name])
        else:
            link = rigid_link(name, _link_frames(name, extra.get(name, {})))
        links.append(link)
    q_ref = {"LCYL": lg.REFERENCE_LIFT_LENGTH, "TCYL": lg.REFERENCE_TILT_LENGTH}
    joints = []
    for j in lg.JOINTS:
        if j.type == "prismatic":
            pf = cf = j.name
        else:
            pf = j.point if j.point != lg.LINK_POINTS.get(j.parent, ("",))[0] else \
                body_frame.get(j.parent, "body")
            cf = j.point if j.point != lg.LINK_POINTS[j.child][0] else \
                body_frame.get(j.child, "body")
        joints.append(Joint(j.name, j.type, j.parent, pf, j.child, cf, (q_ref.get(j.name, 0.0),)))
    mech = build_mechanism(links, joints)
    q0 = mech.q_initial.copy()
    A0 = evaluate_tree(mech, q0, derivatives=False).A
    bodies = {}
    for name, mp in lg.mass_properties().items():
        if name in reduced:
            red, modes = reduced[name]
            bodies[name] = body_from_reduced(red, modes, damping_ratios=[ZETA] * len(modes))
            continue
        A = A0[mech.link_index(name)]
        Rb = A[:3, :3]
        bodies[name] = BodyMass.rigid(mp.mass, Rb.T @ (mp.com - A[:3, 3]), Rb.T @ mp.inertia @ Rb)
    drivers = {"LCYL.d": SmoothStep(0.0, t_lift, lift.min_length, lift.max_length),
               "TCYL.d": SmoothStep(0.0, t_lift, lg.REFERENCE_TILT_LENGTH, tilt.min_length),
               "CHASSIS_X.d": Constant(0.0)}
    load = PointForce("load", ("bucket", "LOAD"), (0.0, 0.0, -lg.RATED_LOAD_N))
    return System(mech, bodies, [0.0, 0.0, -lg.G], forces=[load], drivers=drivers), q0


__all__ = ["R_REV", "build_flexible_loader", "in_plane_modes", "reduce_links"]
