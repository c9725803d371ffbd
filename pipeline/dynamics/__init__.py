"""Lagrange dynamics of rigid/flexible closed-loop machines (DESIGN §4).

Describe a :class:`System` (mechanism, body masses, force elements, drivers,
gravity), then: :func:`equations` (M, rhs), :func:`static_equilibrium`,
:func:`kinetostatics` (actuator forces along a driver motion, joint
reactions), :func:`vibration_modes` (linearised); transient runs are
:func:`pipeline.solver.simulate`. Reduced links enter through
:func:`body_from_reduced` and :func:`link_from_reduced`.
"""

from pipeline.dynamics.bodies import (
    body_from_reduced,
    in_plane_modes,
    link_from_reduced,
    modal_damping,
    project_on_plane,
)
from pipeline.dynamics.energy import energies, kinetic_energy
from pipeline.dynamics.equations import equation_terms, equations
from pipeline.dynamics.forces import FORCES
from pipeline.dynamics.kinetostatics import joint_reactions, kinetostatics
from pipeline.dynamics.linearize import linearize, marker_motion, vibration_modes
from pipeline.dynamics.statics import static_equilibrium
from pipeline.dynamics.system import BodyMass, System, rigid_C

__all__ = [
    "FORCES", "BodyMass", "System", "body_from_reduced", "energies", "equation_terms",
    "equations", "in_plane_modes", "joint_reactions", "kinetic_energy", "kinetostatics",
    "linearize", "link_from_reduced", "marker_motion", "modal_damping", "project_on_plane",
    "rigid_C", "static_equilibrium", "vibration_modes",
]
