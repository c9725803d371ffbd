"""Reduced flexible links and closed-loop Lagrange dynamics of machines.

The package is layered (dependencies point down only)::

    cli -> workflow -> post -> solve/dynamics -> kinematics | invariants
        -> modes -> fem -> meshing -> core

Importing ``pipeline`` is cheap: heavy modules (gmsh, pyvista) are imported
inside the functions that need them.
"""

__version__ = "0.1.0"

from pipeline.core.errors import (
    ArtifactError,
    ConfigError,
    KinematicsError,
    MeshError,
    ModalError,
    PipelineError,
    SolverError,
)

__all__ = [
    "ArtifactError",
    "ConfigError",
    "KinematicsError",
    "MeshError",
    "ModalError",
    "PipelineError",
    "SolverError",
    "__version__",
]
