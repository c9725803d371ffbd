"""The rigid four-bar of benchmark (a), built twice: in the pipeline (joint coordinates, 3D
revolutes, closure rows) and in Exudyn (planar rigid bodies, RevoluteJoint2D, its index-3
generalised-alpha), from the same data: uniform bars crank a, coupler b, rocker c, ground d,
released with the crank at THETA2 turning at OMEGA2 under gravity -y.

Exudyn is a benchmark peer only (``pip install exudyn``), never a dependency: :func:`exudyn_run`
returns None when it is not installed.
"""

from __future__ import annotations

import time

import numpy as np

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.initial import initial_positions, initial_velocities
from pipeline.kinematics.rotations import translation

A_, B_, C_, D_ = 1.0, 2.2, 2.0, 2.5  # m
M_ = (1.0, 3.0, 2.0)  # kg: crank, coupler, rocker
THETA2, OMEGA2, G = 1.2, 3.0, 9.81


def _bar(m, L):
    i = m * L * L / 12.0
    return BodyMass.rigid(m, [0.5 * L, 0.0, 0.0], np.diag([1e-6 * i, i, i]))


def pipeline_model():
    """(System, q0, qd0): coordinates JA (crank), JB (coupler rel.), JC (rocker rel. coupler),
    JD (rocker)."""
    T = translation
    links = [rigid_link("ground", {"D": T([D_, 0, 0])}),
             rigid_link("crank", {"B": T([A_, 0, 0])}),
             rigid_link("coupler", {"C": T([B_, 0, 0])}),
             rigid_link("rocker", {"C": T([C_, 0, 0])})]
    joints = [Joint("JA", "revolute", "ground", "body", "crank", "body", (THETA2,)),
              Joint("JB", "revolute", "crank", "B", "coupler", "body", (-0.85,)),
              Joint("JC", "revolute", "coupler", "C", "rocker", "C", (1.15,)),
              Joint("JD", "revolute", "ground", "D", "rocker", "body", (1.5,))]
    mech = build_mechanism(links, joints)
    s = System(mech, {"crank": _bar(M_[0], A_), "coupler": _bar(M_[1], B_),
                      "rocker": _bar(M_[2], C_)}, gravity=[0.0, -G, 0.0])
    q = initial_positions(mech, mech.q_initial, given={"JA.theta": THETA2})
    return s, q, initial_velocities(mech, q, given={"JA.theta": OMEGA2})


def absolute_angles(q, qd):
    """(angles, rates) of crank, coupler, rocker from the pipeline's joint coordinates."""
    th = np.array([q[0], q[0] + q[1], q[3]])
    w = np.array([qd[0], qd[0] + qd[1], qd[3]])
    return th, w


def exudyn_planar():
    """(exudyn, its ``itemInterface`` module) for planar rigid bodies, or None without
    Exudyn (the planar peers' shared start)."""
    try:
        import exudyn as exu
        from exudyn import itemInterface
    except ImportError:
        return None
    return exu, itemInterface


def solve_planar(exu, mbs, t_end: float, step: float, rho_inf: float):
    """(CPU s, wall s) of Exudyn's index-3 generalised-alpha run of the assembled ``mbs``
    at a fixed step."""
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = round(t_end / step)
    ss.timeIntegration.endTime = t_end
    ss.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    ss.timeIntegration.verboseMode = 0
    ss.solutionSettings.writeSolutionToFile = False
    ss.displayStatistics = False
    c0, w0 = time.process_time(), time.perf_counter()
    exu.SolveDynamic(mbs, ss)
    return time.process_time() - c0, time.perf_counter() - w0


def exudyn_run(q0, qd0, t_end: float, step: float, rho_inf: float = 0.8):
    """CPU seconds, wall seconds and the final crank angle of Exudyn's run from the same
    state; None without Exudyn."""
    peer = exudyn_planar()
    if peer is None:
        return None
    exu, X = peer
    th, w = absolute_angles(q0, qd0)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(X.ObjectGround(referencePosition=[0, 0, 0]))
    origins = [np.zeros(2), A_ * np.array([np.cos(th[0]), np.sin(th[0])]), np.array([D_, 0.0])]
    vel0 = [np.zeros(2), A_ * w[0] * np.array([-np.sin(th[0]), np.cos(th[0])]), np.zeros(2)]
    bodies, nodes = [], []
    for k, L in enumerate((A_, B_, C_)):
        e = np.array([np.cos(th[k]), np.sin(th[k])])
        com = origins[k] + 0.5 * L * e
        v = vel0[k] + 0.5 * L * w[k] * np.array([-e[1], e[0]])
        n = mbs.AddNode(X.NodeRigidBody2D(referenceCoordinates=[com[0], com[1], th[k]],
                                          initialVelocities=[v[0], v[1], w[k]]))
        o = mbs.AddObject(X.ObjectRigidBody2D(physicsMass=M_[k],
                                              physicsInertia=M_[k] * L * L / 12, nodeNumber=n))
        mbs.AddLoad(X.LoadMassProportional(markerNumber=mbs.AddMarker(X.MarkerBodyMass(
            bodyNumber=o)), loadVector=[0, -G, 0]))
        bodies.append(o)
        nodes.append(n)

    def marker(o, x):
        return mbs.AddMarker(X.MarkerBodyPosition(bodyNumber=o, localPosition=[x, 0, 0]))

    cr, cp, rk = bodies
    for m1, m2 in ((marker(ground, 0.0), marker(cr, -A_ / 2)),
                   (marker(cr, A_ / 2), marker(cp, -B_ / 2)),
                   (marker(cp, B_ / 2), marker(rk, C_ / 2)),
                   (marker(ground, D_), marker(rk, -C_ / 2))):
        mbs.AddObject(X.RevoluteJoint2D(markerNumbers=[m1, m2]))
    mbs.Assemble()
    cpu, wall = solve_planar(exu, mbs, t_end, step, rho_inf)
    crank = float(mbs.GetNodeOutput(nodes[0], exu.OutputVariableType.Rotation)[2])
    return cpu, wall, crank
