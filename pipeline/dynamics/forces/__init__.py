"""Force elements by virtual work (thesis eqs. 4.148-4.174; contract in :mod:`.base`).

:data:`FORCES` maps the YAML ``type:`` string to the element class: every class an element
module registers (:func:`pipeline.dynamics.forces.compiled.element_types`).
"""

from pipeline.dynamics.forces.base import ForceElement, MarkerPoint, marker_point, marker_pose
from pipeline.dynamics.forces.compiled import element_types
from pipeline.dynamics.forces.hydraulics import HydraulicCylinder
from pipeline.dynamics.forces.loads import (
                                            FollowerForce,
                                            ForceCylinder,
                                            JointForce,
                                            LineForce,
                                            PointForce,
                                            Torque,
)
from pipeline.dynamics.forces.springs import JointSpringDamper, SpringDamper, TableSpringDamper

#: Force element classes keyed by type name.
FORCES: dict[str, type[ForceElement]] = element_types()

__all__ = ["FORCES", "FollowerForce", "ForceCylinder", "ForceElement", "HydraulicCylinder",
           "JointForce",
           "JointSpringDamper", "LineForce", "MarkerPoint", "PointForce",
           "SpringDamper", "TableSpringDamper", "Torque", "marker_point", "marker_pose"]
