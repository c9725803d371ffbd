"""Link geometry -> mesh (gmsh is imported lazily, only inside ``gmsh_build``).

Public API::

    SolidGeometry, BeamGeometry      what to mesh (frozen, validated)
    MESH_RECIPES                     recipe name -> OCC builder
    build_mesh(geometry, name)       -> MeshData (a solid in its own process, budgeted)
    MeshBudget                       wall time and memory one link's meshing may take
    PhysicalGroup, CylinderSurface, PlaneFace, NearestNode, BoxRegion, SELECTORS
"""

from pipeline.meshing.budget import MeshBudget
from pipeline.meshing.geometry import BeamGeometry, SolidGeometry
from pipeline.meshing.gmsh_build import build_mesh
from pipeline.meshing.mesh_data import MeshData
from pipeline.meshing.recipes import MESH_RECIPES
from pipeline.meshing.selectors import (
    SELECTORS,
    BoxRegion,
    CylinderSurface,
    NearestNode,
    PhysicalGroup,
    PlaneFace,
)

__all__ = [
    "MESH_RECIPES",
    "SELECTORS",
    "BeamGeometry",
    "BoxRegion",
    "CylinderSurface",
    "MeshBudget",
    "MeshData",
    "NearestNode",
    "PhysicalGroup",
    "PlaneFace",
    "SolidGeometry",
    "build_mesh",
]
