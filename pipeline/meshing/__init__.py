"""Link geometry -> mesh (gmsh is imported lazily, only inside this package)."""

from pipeline.meshing.mesh_data import MeshData

__all__ = ["MeshData"]
