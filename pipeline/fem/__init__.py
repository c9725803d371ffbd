"""FE models of links: solids (P2 tetrahedra), point masses, mass moments.

skfem is imported lazily inside the assembly functions, so importing this
package is cheap.
"""

from pipeline.fem.material import Material, check_material, lame_parameters
from pipeline.fem.model import FemModel
from pipeline.fem.moments import MassMoments, mass_moments
from pipeline.fem.point_masses import PointMass, add_point_masses
from pipeline.fem.solid import assemble_solid, p2_topology, solid_moments

__all__ = [
    "FemModel",
    "MassMoments",
    "Material",
    "PointMass",
    "add_point_masses",
    "assemble_solid",
    "check_material",
    "lame_parameters",
    "mass_moments",
    "p2_topology",
    "solid_moments",
]
