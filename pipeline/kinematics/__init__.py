"""Mechanism kinematics on 4x4 matrices (Sheth-Uicker joints, DESIGN §3).

Describe links (:func:`rigid_link`, :func:`flexible_link`) and joints
(:class:`Joint`, types in :data:`JOINTS`), build a :class:`Mechanism`
(topology, loops, coordinate layout), then :func:`assemble`, :func:`dof_report`
and :func:`sweep`. Link poses and their derivatives for the dynamics layer:
:func:`evaluate_tree`. Drivers live in :mod:`pipeline.kinematics.drivers`.
This package imports neither gmsh nor scikit-fem nor the FE side.
"""

from pipeline.kinematics.analysis import (
                                          Assembly,
                                          assemble,
                                          solve_acceleration,
                                          solve_position,
                                          solve_velocity,
)
from pipeline.kinematics.closure import (
                                          ClosureValue,
                                          closure,
                                          closure_gamma,
                                          closure_jacobian,
                                          closure_residual,
)
from pipeline.kinematics.failures import ClosureError, SingularConfigurationError
from pipeline.kinematics.joints import JOINTS, Joint, JointType
from pipeline.kinematics.links import Frame, Link, flexible_link, link_from_frames, rigid_link
from pipeline.kinematics.mechanism import Mechanism, build_mechanism
from pipeline.kinematics.partition import DofReport, Partition, PassiveMotion, dof_report
from pipeline.kinematics.poses import TreeState, evaluate_tree
from pipeline.kinematics.sweep import SweepResult, sweep

__all__ = [
    "JOINTS", "Assembly", "ClosureError", "ClosureValue", "DofReport", "Frame", "Joint",
    "JointType", "Link", "Mechanism", "Partition", "PassiveMotion",
    "SingularConfigurationError", "SweepResult", "TreeState", "assemble", "build_mechanism",
    "closure", "closure_gamma", "closure_jacobian", "closure_residual", "dof_report",
    "evaluate_tree", "flexible_link", "link_from_frames", "rigid_link", "solve_acceleration",
    "solve_position", "solve_velocity", "sweep",
]
