"""The assembled FE model of one link: the seam between ``fem`` and ``modes``.

Contract:

* DOF numbering is owned by the producer; consumers go through ``node_dofs``
  (n_nodes, 3) for solids (ux, uy, uz) or (n_nodes, 6) for beams
  (ux, uy, uz, rx, ry, rz), never assume interleaving.
* ``nodes`` are the DOF-carrying points (for P2 solids: vertices and edge
  midpoints), (n_nodes, 3) in metres in the link frame.
* ``stiffness`` (N/m, N, N m) and ``mass`` (kg, kg m, kg m^2) are symmetric
  CSR (n_dof, n_dof); ``mass`` is consistent and already includes attached
  point masses.
* ``moments`` computes the mass-distribution integrals from the *same* mass
  operator (see :func:`pipeline.fem.moments.mass_moments`), so that
  tr(C''_ab) = phi_a^T M phi_b holds exactly.
* ``extras`` carries element-specific arrays the moments need (e.g. the
  scalar mass matrix of a solid, section properties of a beam).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.sparse as sp


@dataclass(frozen=True)
class FemModel:
    """Stiffness and consistent mass of one link, unconstrained (free-free)."""

    name: str
    kind: str  # "solid" or "beam"
    nodes: np.ndarray  # (n_nodes, 3) m
    node_dofs: np.ndarray  # (n_nodes, 3 | 6) int
    stiffness: sp.csr_matrix  # (n_dof, n_dof)
    mass: sp.csr_matrix  # (n_dof, n_dof)
    extras: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "extras", MappingProxyType(dict(self.extras)))

    @property
    def n_dof(self) -> int:
        return int(self.stiffness.shape[0])

    @property
    def n_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def has_rotations(self) -> bool:
        return self.node_dofs.shape[1] == 6
