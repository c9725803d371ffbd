"""Force elements by virtual work (thesis eqs. 4.148-4.174; contract in :mod:`.base`).

:data:`FORCES` maps the YAML ``type:`` string to the element class.
"""

from pipeline.dynamics.forces.base import ForceElement, MarkerPoint, marker_point, marker_pose
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
FORCES: dict[str, type[ForceElement]] = {
    "spring_damper": SpringDamper,
    "table_spring_damper": TableSpringDamper,
    "joint_spring_damper": JointSpringDamper,
    "point_force": PointForce,
    "follower_force": FollowerForce,
    "line_force": LineForce,
    "torque": Torque,
    "joint_force": JointForce,
    "force_cylinder": ForceCylinder,
    "hydraulic_cylinder": HydraulicCylinder,
}

__all__ = ["FORCES", "FollowerForce", "ForceCylinder", "ForceElement", "HydraulicCylinder",
           "JointForce",
           "JointSpringDamper", "LineForce", "MarkerPoint", "PointForce",
           "SpringDamper", "TableSpringDamper", "Torque", "marker_point", "marker_pose"]
