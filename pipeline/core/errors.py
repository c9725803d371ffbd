"""Exception hierarchy of the pipeline.

Misuse and bad input raise one of these; numerical failure of a long run
comes back as a status on its result object instead (see STYLE.md §1.9).
Messages name the source (file, link, YAML path) and say what was expected.
"""

from __future__ import annotations


class PipelineError(Exception):
    """Base class of every error the pipeline raises on purpose."""


class ConfigError(PipelineError, ValueError):
    """Bad user input: a spec field, a file, a value out of range."""


class MeshError(PipelineError):
    """Meshing failed or the geometry source is unusable."""


class ModalError(PipelineError):
    """The FE model cannot be reduced as asked (e.g. too many modes)."""


class KinematicsError(PipelineError):
    """Topology or loop-closure problems (cannot assemble, singular)."""


class SolverError(PipelineError):
    """A solver was called in a way it cannot honour."""


class ArtifactError(PipelineError):
    """A stored artifact is missing, truncated, corrupted or of another version."""
