"""Small mechanisms built in 3D for the kinematics tests (planar ones in the x-y plane).

Each builder returns the :class:`Mechanism`; the joint-variable meaning is
stated so the tests can map closed-form angles onto coordinates.
"""

from __future__ import annotations

import numpy as np

from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
from pipeline.kinematics.rotations import homogeneous, inverse, rot_y, translation

T = translation


def slider_crank(r: float, l: float, e: float, theta0: float = 0.3):
    """Crank r about z at the origin, rod l, slider on the line y = e (prismatic along x).

    Coordinates: crank.theta = theta, pin.theta = phi - theta, wrist.theta = -phi,
    slide.d = x (slider position), with phi the rod angle (closed_form conventions).
    """
    links = [
        rigid_link("ground", {"rail": homogeneous(rot_y(np.pi / 2), [0.0, e, 0.0])}),
        rigid_link("crank", {"A": T([r, 0, 0])}),
        rigid_link("rod", {"B": T([l, 0, 0])}),
        rigid_link("slider", {"rail": homogeneous(rot_y(np.pi / 2))}),
    ]
    phi0 = np.arcsin((e - r * np.sin(theta0)) / l) + 0.05  # rough guess
    joints = [
        Joint("crank", "revolute", "ground", "body", "crank", "body", (theta0,)),
        Joint("slide", "prismatic", "ground", "rail", "slider", "rail",
              (r * np.cos(theta0) + l * np.cos(phi0) - 0.02,)),
        Joint("pin", "revolute", "crank", "A", "rod", "body", (phi0 - theta0,)),
        Joint("wrist", "revolute", "rod", "B", "slider", "body", (-phi0,)),
    ]
    return build_mechanism(links, joints)


def four_bar(a, b, c, d, theta2=0.4, theta3=0.5, theta4=1.5, flexible=None):
    """Four-bar: crank a at O2 = 0, coupler b, rocker c at O4 = (d, 0, 0), all about z.

    Coordinates: J2.theta = theta2, J3.theta = theta3 - theta2,
    J4.theta = theta4 - theta3, J1.theta = theta4 (closed_form angles).
    ``flexible = (phi (m, 3), psi (m, 3))`` makes the coupler flexible with
    that modal motion at its distal frame B (body frame at A, x along A->B).
    """
    coupler = (rigid_link("coupler", {"B": T([b, 0, 0])}) if flexible is None else
               flexible_link("coupler", {"B": (T([b, 0, 0]), flexible[0], flexible[1])}))
    links = [rigid_link("ground", {"O4": T([d, 0, 0])}),
             rigid_link("crank", {"A": T([a, 0, 0])}), coupler,
             rigid_link("rocker", {"B": T([c, 0, 0])})]
    joints = [
        Joint("J2", "revolute", "ground", "body", "crank", "body", (theta2,)),
        Joint("J3", "revolute", "crank", "A", "coupler", "body", (theta3 - theta2,)),
        Joint("J4", "revolute", "coupler", "B", "rocker", "B", (theta4 - theta3,)),
        Joint("J1", "revolute", "ground", "O4", "rocker", "body", (theta4,)),
    ]
    return build_mechanism(links, joints)


def rssr(theta_ref=0.5, psi_ref=0.3, a=1.0, c=2.0, pivot=(3.0, 0.0, 1.0)):
    """Spatial RSSR: crank a about global z at the origin; rocker c about global x
    at ``pivot``; coupler with spherical joints at both pins.

    Crank pin A = a (cos t, sin t, 0), rocker pin B = pivot + c (0, cos p, sin p);
    the coupler length is |B - A| at the reference (t, p) = (theta_ref, psi_ref),
    where every frame is assembled with the global orientation (spherical
    angles zero). Coordinates: crank.theta = t, rocker.theta = p + pi/2.
    Returns (mechanism, coupler length).
    """
    P = np.asarray(pivot, dtype=float)
    A = a * np.array([np.cos(theta_ref), np.sin(theta_ref), 0.0])
    B = P + c * np.array([0.0, np.cos(psi_ref), np.sin(psi_ref)])
    Hc = homogeneous(_rz(theta_ref))  # crank body at the reference
    Hr_axis = homogeneous(rot_y(np.pi / 2), P)  # rocker joint frame: z = global x
    Hr = Hr_axis @ homogeneous(_rz(psi_ref + np.pi / 2))  # rocker body, x toward B
    links = [
        rigid_link("ground", {"R2": Hr_axis}),
        rigid_link("crank", {"A": inverse(Hc) @ homogeneous(np.eye(3), A)}),
        rigid_link("coupler", {"B": T(B - A)}),
        rigid_link("rocker", {"B": inverse(Hr) @ homogeneous(np.eye(3), B)}),
    ]
    joints = [
        Joint("crank", "revolute", "ground", "body", "crank", "body", (theta_ref,)),
        Joint("S1", "spherical", "crank", "A", "coupler", "body"),
        Joint("S2", "spherical", "coupler", "B", "rocker", "B"),
        Joint("rocker", "revolute", "ground", "R2", "rocker", "body", (psi_ref + np.pi / 2,)),
    ]
    return build_mechanism(links, joints), float(np.linalg.norm(B - A))


def rssr_rocker(t, b, psi_near, a=1.0, c=2.0, pivot=(3.0, 0.0, 1.0)):
    """Closed-form rocker angle p(t) of :func:`rssr` on the branch nearest ``psi_near``.

    From |pivot + c (0, cos p, sin p) - A(t)| = b with D = pivot - A(t):
    D_y cos p + D_z sin p = (b^2 - |D|^2 - c^2) / (2 c).
    """
    D = np.asarray(pivot, dtype=float) - a * np.array([np.cos(t), np.sin(t), 0.0])
    K = (b * b - D @ D - c * c) / (2.0 * c)
    rho, base = np.hypot(D[1], D[2]), np.arctan2(D[2], D[1])
    roots = base + np.array([1.0, -1.0]) * np.arccos(K / rho)
    k = np.argmin(np.abs(np.angle(np.exp(1j * (roots - psi_near)))))
    return float(psi_near + np.angle(np.exp(1j * (roots[k] - psi_near))))


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def wrist_loop():
    """Three revolutes about z, x', y'' (all through the origin) from ground to
    link L3, and a spherical joint from ground to L3 at the origin: the
    spherical follows R = rot_z(a) rot_x(b) rot_y(c) of the driven revolutes
    (coordinates R1.theta = a, R2.theta = b, R3.theta = c; assembled at 0)."""
    Fx, Fy = homogeneous(rot_y(np.pi / 2)), homogeneous(_rx(-np.pi / 2))
    links = [rigid_link("ground"), rigid_link("L1", {"ax": Fx}),
             rigid_link("L2", {"ax": Fx, "ay": Fy}), rigid_link("L3", {"ay": Fy})]
    joints = [Joint("R1", "revolute", "ground", "body", "L1", "body"),
              Joint("S", "spherical", "ground", "body", "L3", "body", (0.01, 0.02, -0.01)),
              Joint("R2", "revolute", "L1", "ax", "L2", "ax"),
              Joint("R3", "revolute", "L2", "ay", "L3", "ay")]
    return build_mechanism(links, joints)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def five_bar(l1=0.5, l2=0.8, l3=0.8, l4=0.5, d=1.0, guess=(1.6, -1.2, -1.0, -1.6, 1.4)):
    """Planar five-bar (2 DOF): crank l1 at the origin (joint J1), links l2, l3,
    crank l4 at (d, 0, 0) (joint J5); J2..J4 relative angles; cut at J4."""
    links = [rigid_link("ground", {"O5": T([d, 0, 0])}), rigid_link("c1", {"A": T([l1, 0, 0])}),
             rigid_link("b2", {"B": T([l2, 0, 0])}), rigid_link("b3", {"C": T([l3, 0, 0])}),
             rigid_link("c4", {"C": T([l4, 0, 0])})]
    joints = [Joint("J1", "revolute", "ground", "body", "c1", "body", (guess[0],)),
              Joint("J2", "revolute", "c1", "A", "b2", "body", (guess[1],)),
              Joint("J3", "revolute", "b2", "B", "b3", "body", (guess[2],)),
              Joint("J4", "revolute", "b3", "C", "c4", "C", (guess[3],)),
              Joint("J5", "revolute", "ground", "O5", "c4", "body", (guess[4],))]
    return build_mechanism(links, joints)
