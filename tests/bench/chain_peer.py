"""The planar N-bar open chain of the scaling benchmark, built twice from the same data:
in the pipeline (joint coordinates, 3D revolutes about z) and in Exudyn (planar rigid
bodies, RevoluteJoint2D, its index-3 generalised-alpha). N uniform bars of length L and
mass M hang from a ground pin, each pinned to the tip of the last, released at rest
along +x under gravity -y.

Exudyn is a benchmark peer only (``pip install exudyn``), never a dependency:
:func:`exudyn_run` returns None when it is not installed.
"""

from __future__ import annotations

import numpy as np
from fourbar_peer import exudyn_planar, solve_planar

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.rotations import translation

L, M, G = 0.5, 1.0, 9.81  # m, kg, m/s^2


def pipeline_model(n: int) -> System:
    """The chain of ``n`` bars; coordinate k is bar k's angle relative to bar k - 1."""
    links = [rigid_link("ground")] + [rigid_link(f"bar{k}", {"tip": translation([L, 0, 0])})
                                      for k in range(n)]
    joints = [Joint(f"J{k}", "revolute", "ground" if k == 0 else f"bar{k - 1}",
                    "body" if k == 0 else "tip", f"bar{k}", "body", (0.0,))
              for k in range(n)]
    inertia = M * L * L / 12.0
    bodies = {f"bar{k}": BodyMass.rigid(M, [0.5 * L, 0.0, 0.0],
                                        np.diag([1e-6 * inertia, inertia, inertia]))
              for k in range(n)}
    return System(build_mechanism(links, joints), bodies, gravity=[0.0, -G, 0.0])


def exudyn_run(n: int, t_end: float, step: float, rho_inf: float = 0.8):
    """(CPU seconds, the first bar's angle at t_end) of Exudyn's run; None without Exudyn."""
    peer = exudyn_planar()
    if peer is None:
        return None
    exu, X = peer
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(X.ObjectGround(referencePosition=[0, 0, 0]))
    last = mbs.AddMarker(X.MarkerBodyPosition(bodyNumber=ground, localPosition=[0, 0, 0]))
    first = None
    for k in range(n):
        node = mbs.AddNode(X.NodeRigidBody2D(referenceCoordinates=[(k + 0.5) * L, 0.0, 0.0],
                                             initialVelocities=[0.0, 0.0, 0.0]))
        body = mbs.AddObject(X.ObjectRigidBody2D(physicsMass=M, physicsInertia=M * L * L / 12,
                                                 nodeNumber=node))
        first = node if first is None else first
        mbs.AddLoad(X.LoadMassProportional(markerNumber=mbs.AddMarker(X.MarkerBodyMass(
            bodyNumber=body)), loadVector=[0, -G, 0]))
        here = mbs.AddMarker(X.MarkerBodyPosition(bodyNumber=body,
                                                  localPosition=[-L / 2, 0, 0]))
        mbs.AddObject(X.RevoluteJoint2D(markerNumbers=[last, here]))
        last = mbs.AddMarker(X.MarkerBodyPosition(bodyNumber=body, localPosition=[L / 2, 0, 0]))
    mbs.Assemble()
    cpu, _ = solve_planar(exu, mbs, t_end, step, rho_inf)
    return cpu, float(mbs.GetNodeOutput(first, exu.OutputVariableType.Rotation)[2])
