"""The flexible pendulum of benchmark (b), built twice from one finite-element model.

The aluminium bar of meshes/al_bar.yaml (0.4 x 0.008 x 0.004 m, P2 tetrahedra) pinned at its
root about the global z axis (across its 8 mm side), released horizontal under gravity -y.

* The pipeline: the bar reduced to its 8 lowest modes clamped at the root (RBE2), the exact
  reduced kinetic energy and gravity (the deformed centre of mass included).
* Exudyn (a benchmark peer only, never a dependency; None when not installed): the same mesh,
  stiffness and mass matrices handed to its FEMinterface, Hurty-Craig-Bampton modes with the
  root tied (RBE2, 8 eigenmodes), its ObjectFFRFreducedOrder with a revolute joint at the
  root and its mass-proportional gravity (which ignores the deformed centre of mass).

Each code is compared with its own converged run (the reduced models differ slightly).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
L_BAR = 0.4


def fe_and_reduced(folder: Path, mesh_size: float | None = None, modes: int = 8):
    """(ReducedLink, FemModel, root node indices) of the bar; ``mesh_size`` None keeps the
    shipped one (about 55 800 DOF)."""
    from pipeline.invariants.reduce import _assemble
    from pipeline.meshing import build_mesh
    from pipeline.workflow.link_build import link_request, reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    spec = load_link_spec(ROOT / "meshes" / "al_bar.yaml")
    geometry = spec.geometry if mesh_size is None else \
        spec.geometry.model_copy(update={"mesh_size": mesh_size})
    spec = spec.model_copy(update={"geometry": geometry,
                                   "modes": spec.modes.model_copy(update={"count": modes})})
    red = reduce_spec(spec, ROOT / "meshes", folder / "links")[0]
    request, _ = link_request(spec, ROOT / "meshes")
    mesh = build_mesh(request.geometry, spec.name)
    model = _assemble(request, mesh)
    root = np.flatnonzero(np.abs(model.nodes[:, 0]) < 1e-9)
    return red, model, root


def pipeline_model(red):
    """System of the pendulum, q = (pin angle, modal coordinates): the pin frame is the
    mesh's own frame (z across the 4 mm side), so at q = 0 the bar lies along +x and
    bends in the xy plane across its 8 mm side, as in Exudyn's model."""
    from pipeline.dynamics import System, body_from_reduced, link_from_reduced
    from pipeline.kinematics import Joint, build_mechanism, rigid_link

    pin = np.linalg.inv(red.body_pose)  # the geometry frame in the body (root) frame
    link = link_from_reduced(red, name="bar", frames={"pin": ("root", pin)})
    mech = build_mechanism([rigid_link("ground"), link],
                           [Joint("pin", "revolute", "ground", "body", "bar", "pin")])
    return System(mech, {"bar": body_from_reduced(red)}, gravity=[0.0, -9.81, 0.0])


def tip_positions(system, q: np.ndarray) -> np.ndarray:
    """(k, 3) positions of the tip interface's origin for the coordinate rows q (k, n)."""
    from pipeline.dynamics.forces.base import marker_pose
    from pipeline.kinematics import evaluate_tree

    out = []
    for qk in q:
        tree = evaluate_tree(system.mechanism, qk, derivatives=False)
        out.append(marker_pose(system, "bar", "tip", tree, qk)[:3, 3])
    return np.array(out)


def exudyn_run(model, root, t_end: float, step: float, n_out: int, modes: int = 8,
               rho_inf: float = 0.8):
    """(CPU s, wall s, tip positions (n_out, 3)) of Exudyn's run; None without Exudyn."""
    try:
        import exudyn as exu
        from exudyn.FEM import FEMinterface, HCBstaticModeSelection, ObjectFFRFreducedOrderInterface
        from exudyn.itemInterface import (
            GenericJoint,
            MarkerBodyRigid,
            MarkerSuperElementPosition,
            MarkerSuperElementRigid,
            ObjectGround,
            SensorMarker,
        )
    except ImportError:
        return None
    # Exudyn expects 3 DOF per node, node-major: renumber the pipeline's P2 DOF to that
    node_major = model.node_dofs.ravel()
    fem = FEMinterface()
    fem.nodes = {"Position": np.array(model.nodes)}
    fem.massMatrix = model.mass.tocsr()[node_major][:, node_major]
    fem.stiffnessMatrix = model.stiffness.tocsr()[node_major][:, node_major]
    fem.ComputeHurtyCraigBamptonModes(boundaryNodesList=[list(map(int, root))],
                                      nEigenModes=modes, useSparseSolver=True,
                                      computationMode=HCBstaticModeSelection.RBE2)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    cms = ObjectFFRFreducedOrderInterface(fem)
    obj = cms.AddObjectFFRFreducedOrder(mbs, positionRef=[0, 0, 0], initialVelocity=[0, 0, 0],
                                        initialAngularVelocity=[0, 0, 0],
                                        gravity=[0, -9.81, 0])
    body = obj["oFFRFreducedOrder"]
    w = np.ones(root.size) / root.size
    m_root = mbs.AddMarker(MarkerSuperElementRigid(bodyNumber=body, meshNodeNumbers=root,
                                                   weightingFactors=w))
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    m_ground = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
    mbs.AddObject(GenericJoint(markerNumbers=[m_ground, m_root],
                               constrainedAxes=[1, 1, 1, 1, 1, 0]))
    tip = np.flatnonzero(np.abs(model.nodes[:, 0] - L_BAR) < 1e-9)
    m_tip = mbs.AddMarker(MarkerSuperElementPosition(bodyNumber=body, meshNodeNumbers=tip,
                                                     weightingFactors=np.ones(tip.size)
                                                     / tip.size))
    sensor = mbs.AddSensor(SensorMarker(markerNumber=m_tip, storeInternal=True,
                                        outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    ss = exu.SimulationSettings()  # the settings names of Exudyn 1.9-1.13 (deprecated later)
    ss.timeIntegration.numberOfSteps = round(t_end / step)
    ss.timeIntegration.endTime = t_end
    ss.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    ss.timeIntegration.verboseMode = 0
    ss.solutionSettings.writeSolutionToFile = False
    ss.solutionSettings.sensorsWritePeriod = t_end / (n_out - 1)
    ss.displayStatistics = False
    c0, w0 = time.process_time(), time.perf_counter()
    exu.SolveDynamic(mbs, ss)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    values = mbs.GetSensorStoredData(sensor)
    return cpu, wall, values
