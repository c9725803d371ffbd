"""The reduced flexible link: the only thing the multibody side sees of the FE side.

Like an ADAMS MNF, one :class:`ReducedLink` per link holds the mass-distribution
matrices (DESIGN §2), the modal stiffness and mass, the frequencies, the
modal translations ``phi`` and small rotations ``psi`` of every interface and
marker, the undeformed mesh with full-field mode shapes (for rendering and
stress recovery) and the provenance (settings, versions, input hash).

Every array is expressed in the link's **body frame** = the frame of its
reference interface (the proximal joint): origin at that interface's
reference point, axes those of the joint frame. Units are SI.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np


@dataclass(frozen=True)
class FrameModes:
    """A named frame on the link (interface or marker) and its modal motion.

    Attributes
    ----------
    name : str
    pose : (4, 4) undeformed pose of the frame in the body frame (rigid S0).
    phi : (m, 3) translation of the frame origin per unit modal coordinate, m.
    psi : (m, 3) small rotation of the frame per unit modal coordinate, rad.
    kind : "interface" or "marker".
    """

    name: str
    pose: np.ndarray
    phi: np.ndarray
    psi: np.ndarray
    kind: str = "interface"


@dataclass(frozen=True)
class ReducedLink:
    """Reduced flexible (or rigid, ``n_modes == 0``) link in its body frame.

    Attributes
    ----------
    name : str
    kind : "solid" or "beam".
    body_pose : (4, 4) pose of the body frame in the geometry frame the link
        was described in.
    C : (4, 4) int rho r r^T dV (kg, kg m, kg m^2).
    Cp : (m, 4, 4) C'_a = int rho r phi_a^T dV.
    Cpp : (m, m, 4, 4) C''_ab = int rho phi_a phi_b^T dV.
    modal_stiffness, modal_mass : (m, m) Phi^T K Phi, Phi^T M Phi.
    frequencies_hz : (m,) frequencies of the clamped (or CB-reduced) modes.
    mode_kinds : (m,) "normal" or "constraint".
    frames : interfaces first (the reference one first), then markers.
    nodes : (N, 3) FE nodes in the body frame, m.
    cells : (k, p) volume (tetra10) or line cells into ``nodes``.
    surface : (t, q) boundary triangles into ``nodes`` (empty for beams).
    mode_shapes : (m, N, 3) nodal translations per unit modal coordinate, m.
    meta : provenance and settings (JSON-serialisable).
    geometric_stiffness : (6, m, m) centrifugal geometric stiffness K_G,c per unit
        product of body angular-velocity components (see
        :mod:`pipeline.invariants.stiffening`), N m s^2; (0, m, m) when not computed.
    force_geometric_stiffness : (F, 3, m, m) geometric stiffness per unit force (N) along
        each body axis at each frame (in ``frames`` order), N m / N; (0, 3, m, m) when not
        computed.
    inertia_geometric_stiffness : (4, 3, m, m) geometric stiffness of the unit inertia
        cases, body force rho xb_j e_k with xb = [x, y, z, 1] in body axes (see
        :mod:`pipeline.invariants.stiffening`); (0, 3, m, m) when not computed.
    stress_modes : (m, N, 6) float32 per unit modal coordinate at the nodes: solids the
        stress in body axes, Voigt [xx, yy, zz, yz, xz, xy], Pa; beams the section
        resultants [N, Vy, Vz, T, My, Mz] in element axes, N and N m
        (:mod:`pipeline.fem.stress`); (0, N, 6) when not computed.
    """

    name: str
    kind: str
    body_pose: np.ndarray
    C: np.ndarray
    Cp: np.ndarray
    Cpp: np.ndarray
    modal_stiffness: np.ndarray
    modal_mass: np.ndarray
    frequencies_hz: np.ndarray
    mode_kinds: tuple[str, ...]
    frames: tuple[FrameModes, ...]
    nodes: np.ndarray
    cells: np.ndarray
    surface: np.ndarray
    mode_shapes: np.ndarray
    meta: Mapping[str, Any] = field(default_factory=dict)
    geometric_stiffness: np.ndarray | None = None
    stress_modes: np.ndarray | None = None
    force_geometric_stiffness: np.ndarray | None = None
    inertia_geometric_stiffness: np.ndarray | None = None

    def __post_init__(self) -> None:
        m = int(self.frequencies_hz.shape[0])
        if self.geometric_stiffness is None:
            object.__setattr__(self, "geometric_stiffness", np.zeros((0, m, m)))
        if self.force_geometric_stiffness is None:
            object.__setattr__(self, "force_geometric_stiffness", np.zeros((0, 3, m, m)))
        if self.inertia_geometric_stiffness is None:
            object.__setattr__(self, "inertia_geometric_stiffness", np.zeros((0, 3, m, m)))
        if self.stress_modes is None:
            object.__setattr__(self, "stress_modes",
                               np.zeros((0, int(self.nodes.shape[0]), 6), np.float32))
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))
        object.__setattr__(self, "mode_kinds", tuple(self.mode_kinds))
        object.__setattr__(self, "frames", tuple(self.frames))

    @property
    def n_modes(self) -> int:
        return int(self.frequencies_hz.shape[0])

    @property
    def mass(self) -> float:
        """Total mass, kg."""
        return float(self.C[3, 3])

    @property
    def center_of_mass(self) -> np.ndarray:
        """(3,) centre of mass in the body frame, m."""
        return self.C[:3, 3] / self.C[3, 3]

    @property
    def inertia_tensor(self) -> np.ndarray:
        """(3, 3) inertia tensor about the centre of mass, body axes, kg m^2."""
        c = self.center_of_mass
        S = self.C[:3, :3] - self.mass * np.outer(c, c)
        return np.trace(S) * np.eye(3) - S

    @property
    def chord(self) -> str | None:
        """The far interface of a chord reference (``modes.chord``), else None: the
        reference interface's frame is then the chord's (the line through the two pins),
        not the end's."""
        return (self.meta.get("reference_conditions") or {}).get("chord")

    def frame_hessians(self, modes=None) -> np.ndarray | None:
        """(F, m, m, 3) second derivatives of the frames' translations, d2r_f/deta_a
        deta_b (m per modal unit^2, body axes, frames in order) of the kept ``modes``
        (default all): ``-K_F,f,k`` of the unit force cases
        (:mod:`pipeline.invariants.stiffening`); None without geometric stiffening."""
        return _second_derivatives(self.force_geometric_stiffness, modes, (0, 2, 3, 1))

    def second_order_moments(self, modes=None) -> np.ndarray | None:
        """(m, m, 4, 3) G_ab[j, k] = d2(int rho xb_j u_k dV)/deta_a deta_b, the second-order
        moments of the link's mass (xb = [x, y, z, 1] body coordinates, u its displacement,
        body axes; kg m^2 and kg m per modal unit^2) of the kept ``modes`` (default all):
        ``-K_jk`` of the unit inertia cases
        (:func:`pipeline.invariants.stiffening.inertia_stiffness`); None without
        geometric stiffening. G_ab[3] is the second-order first moment."""
        return _second_derivatives(self.inertia_geometric_stiffness, modes, (2, 3, 0, 1))

    def frame(self, name: str) -> FrameModes:
        """The frame called ``name``; KeyError lists the available ones."""
        for f in self.frames:
            if f.name == name:
                return f
        raise KeyError(f"link {self.name!r} has no frame {name!r}; "
                       f"available: {[f.name for f in self.frames]}")

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary: sizes, mass properties, frequencies, timings."""
        return {
            "name": self.name,
            "kind": self.kind,
            "nodes": int(self.nodes.shape[0]),
            "dof": int(self.meta.get("n_dof", 0)),
            "mass_kg": self.mass,
            "center_of_mass_m": self.center_of_mass.tolist(),
            "inertia_kgm2": self.inertia_tensor.tolist(),
            "n_modes": self.n_modes,
            "frequencies_hz": self.frequencies_hz.tolist(),
            "mode_kinds": list(self.mode_kinds),
            "frames": [f.name for f in self.frames],
            "stage_seconds": dict(self.meta.get("stage_seconds", {})),
            "factorisation": self.meta.get("factorisation"),
            "peak_memory_mib": self.meta.get("peak_memory_mib"),
            "reference_conditions": self._reference_conditions(),
            "geometric_stiffening": ({"inertia_cases": len(gs.get("inertia_cases", ())),
                                      "frame_forces": list(gs.get("frame_forces", ()))}
                                     if (gs := self.meta.get("geometric_stiffening")) else None),
            "input_hash": self.meta.get("input_hash", ""),
        }

    def _reference_conditions(self) -> str | None:
        """What the modes are relative to, in words (None for an artifact that does not
        record it)."""
        rc = self.meta.get("reference_conditions") or {}
        ref = rc.get("reference")
        if ref is None:
            return None
        if rc.get("chord"):
            return f"chord from {ref!r} to {rc['chord']!r} (pinned-pinned)"
        n_constraint = sum(k == "constraint" for k in self.mode_kinds)
        if n_constraint:
            names = rc.get("craig_bampton") or ["the other interfaces"]  # older artifacts
            return (f"clamped at {ref!r}, with {n_constraint} constraint modes (Craig-Bampton: "
                    f"{', '.join(names)})")
        return f"clamped at {ref!r}"


def _second_derivatives(K, modes, axes) -> np.ndarray | None:
    """Second derivatives from geometric stiffnesses K (..., m, m) by virtual work: -K on
    the kept ``modes`` (None: all) of its last two axes, transposed by ``axes``; None if
    K is empty (no geometric stiffening)."""
    K = np.asarray(K, dtype=float)
    if not K.size:
        return None
    if modes is not None:
        idx = list(modes)
        K = K[..., idx, :][..., idx]
    return -np.transpose(K, axes)
