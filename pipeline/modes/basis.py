"""The modal basis of one link and the conventions that make it reproducible.

Conventions (every producer in :mod:`pipeline.modes` applies them):

* mass-normalised: Phi^T M Phi = I;
* ordered by increasing frequency;
* deterministic sign: in each full DOF vector, the entry of largest magnitude
  is positive (ties within a relative 1e-8 go to the lowest DOF index, so
  round-off cannot flip the choice between symmetric twins).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np


@dataclass(frozen=True)
class ModalBasis:
    """Clamped (fixed-interface, optionally Craig-Bampton) modes of a link.

    Attributes
    ----------
    frequencies_hz : (m,) natural frequencies of the (reduced) model, Hz.
    shapes : (n_dof, m) full DOF vectors of the unreduced FemModel (expanded
        through the RBE2 transformation), m per unit modal coordinate.
    reduced_shapes : (n_red, m) the same modes in the tied coordinates u_r
        (RBE2 master DOFs included), used to read interface motions.
    modal_stiffness : (m, m) Phi^T K Phi, N m (diagonal = omega^2 for unit modal mass).
    modal_mass : (m, m) Phi^T M Phi (identity).
    kinds : (m,) "normal" (fixed-interface) or "constraint" (Craig-Bampton static).
    reference : name of the clamped (reference) interface.
    settings : how the basis was computed (JSON-serialisable).
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    reduced_shapes: np.ndarray
    modal_stiffness: np.ndarray
    modal_mass: np.ndarray
    kinds: tuple[str, ...]
    reference: str
    settings: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "kinds", tuple(self.kinds))
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))

    @property
    def n_modes(self) -> int:
        return int(self.frequencies_hz.shape[0])

    @property
    def omega(self) -> np.ndarray:
        """(m,) circular frequencies, rad/s."""
        return 2.0 * np.pi * self.frequencies_hz


def sign_flips(shapes: np.ndarray, rtol: float = 1e-8) -> np.ndarray:
    """(m,) +1/-1 factors that make each column's largest-magnitude entry positive.

    Examples
    --------
    >>> sign_flips(np.array([[1.0, 0.2], [-3.0, 0.1]]))
    array([-1.,  1.])
    """
    a = np.abs(shapes)
    peak = a.max(axis=0)
    # first index whose magnitude is within rtol of the peak: robust to round-off ties
    idx = np.argmax(a >= peak * (1.0 - rtol), axis=0)
    s = np.sign(shapes[idx, np.arange(shapes.shape[1])])
    s[s == 0] = 1.0
    return s


def frequencies_from_eigenvalues(lam: np.ndarray) -> np.ndarray:
    """Hz from omega^2 (rad^2/s^2); round-off negatives of a clamped model clip to 0."""
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)
