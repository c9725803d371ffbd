"""Modal reduction of a tied link: clamped modes, Craig-Bampton, interface motions."""

from pipeline.modes.basis import ModalBasis
from pipeline.modes.clamp import ClampedProblem, ClampedSpace, clamp_chord, clamp_reference
from pipeline.modes.clamped import clamped_modes
from pipeline.modes.craig_bampton import craig_bampton_basis
from pipeline.modes.eigen import ORDERINGS, factorize, lowest_modes
from pipeline.modes.frame_motion import frame_motion

__all__ = [
    "ORDERINGS",
    "ClampedProblem",
    "ClampedSpace",
    "ModalBasis",
    "clamp_chord",
    "clamp_reference",
    "clamped_modes",
    "craig_bampton_basis",
    "factorize",
    "frame_motion",
    "lowest_modes",
]
