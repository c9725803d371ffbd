"""BodyMass and kinematics Link from a ReducedLink (mode subset, modal or Rayleigh damping).

Examples
--------
>>> import numpy as np
>>> D = modal_damping(np.diag([4.0, 9.0]), np.eye(2), ratios=[0.01, 0.02], link="arm")
>>> np.round(np.diag(D), 6).tolist()  # 2 zeta omega
[0.04, 0.12]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla

from pipeline.core.errors import ConfigError
from pipeline.dynamics.system import BodyMass
from pipeline.invariants.planar_modes import PLANES, link_mode_planes, without_plane_round_off
from pipeline.kinematics.links import Link, link_from_frames

__all__ = ["PLANES", "FrameView", "body_from_reduced", "frame_views", "in_plane_modes",
           "link_from_reduced", "modal_damping", "project_on_plane", "select_modes"]



def _plane(plane: str) -> tuple[int, tuple[int, int]]:
    if plane not in PLANES:
        raise ConfigError(f"plane: expected one of {sorted(PLANES)}, got {plane!r}")
    return PLANES[plane]


def in_plane_modes(reduced, plane: str, tol: float = 1e-2, energy_tol: float = 1e-3
                   ) -> tuple[int, ...]:
    """Indices of the modes that move in ``plane`` of the body frame ("xy", "yz" or "xz").

    A mode is kept when either test says so:

    * frames: out-of-plane translation and rotations of every frame at most ``tol`` times
      the in-plane ones (the joints see an in-plane mode). A body symmetric about the
      plane has modes symmetric about it whose walls breathe across it (a box's panel
      modes): much of their energy is out of the plane, none of their frames' motion.
    * energy: for a mode whose kinetic energy is mostly translation of its mass (every
      solid mode; a beam's bending and axial modes, not its torsion), the share of that
      energy out of the plane, ``C''_aa[t, t] / tr C''_aa`` (the mass invariant), is at
      most ``energy_tol``. On a mesh that is not symmetric about the plane (one element
      through a plate), an in-plane mode next to an out-of-plane one takes a few per cent
      of its *frame* motion from it while keeping 1e-5 of its energy out of the plane.

    Planar loops need none of the others (the DAE formulation also runs with them: the
    loops then constrain them)."""
    t_out, r_out = _plane(plane)
    t_in = [a for a in range(3) if a != t_out]
    r_in = next(a for a in range(3) if a not in r_out)
    Cpp = np.asarray(reduced.Cpp, dtype=float)
    modal_mass = np.diag(np.asarray(reduced.modal_mass, dtype=float))
    keep = []
    for a in range(reduced.n_modes):
        P = Cpp[a, a, :3, :3]
        translational = np.trace(P) >= 0.5 * modal_mass[a]
        out = max(max(abs(f.phi[a, t_out]), *np.abs(f.psi[a, list(r_out)]))
                  for f in reduced.frames)
        inp = max(max(*np.abs(f.phi[a, t_in]), abs(f.psi[a, r_in])) for f in reduced.frames)
        if out <= tol * inp or (translational and P[t_out, t_out] <= energy_tol * np.trace(P)):
            keep.append(a)
    return tuple(keep)


def project_on_plane(phi: np.ndarray, psi: np.ndarray, plane: str
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(phi, psi) (m, 3) of a frame with their out-of-plane components set to zero: a planar
    loop cannot follow the residual out-of-plane motion of in-plane modes (its out-of-plane
    rows would lock them)."""
    _plane(plane)
    return without_plane_round_off(phi, psi, ((plane,),) * len(phi))


def select_modes(n_modes: int, modes: Sequence[int] | None, link: str) -> np.ndarray:
    """Indices (k,) of the kept modes (0-based; None keeps all)."""
    if modes is None:
        return np.arange(n_modes)
    idx = np.asarray(list(modes), dtype=int)
    if idx.ndim != 1 or np.any(idx < 0) or np.any(idx >= n_modes) or len(set(idx)) != idx.size:
        raise ConfigError(f"link '{link}': modes: expected distinct indices in [0, {n_modes}), "
                          f"got {list(modes)}")
    return idx


def modal_damping(K: np.ndarray, Mm: np.ndarray, *, ratios=None, rayleigh=None,
                  link: str = "?") -> np.ndarray:
    """(m, m) modal damping matrix.

    Parameters
    ----------
    K, Mm : (m, m) modal stiffness and modal mass.
    ratios : (m,) damping ratio per mode: D = Mm W diag(2 zeta omega) W^T Mm
        with the modes W of (K, Mm) (diag(2 zeta omega) for normal modes).
    rayleigh : (alpha, beta): D = alpha Mm + beta K (1/s, s).
    """
    m = K.shape[0]
    if ratios is not None and rayleigh is not None:
        raise ConfigError(f"link '{link}': damping: give ratios or rayleigh, not both")
    if rayleigh is not None:
        a, b = (float(x) for x in rayleigh)
        if not (np.isfinite(a) and np.isfinite(b) and a >= 0 and b >= 0):
            raise ConfigError(f"link '{link}': damping.rayleigh: expected finite (alpha, beta) "
                              f">= 0, got {tuple(rayleigh)}")
        return a * Mm + b * K
    if ratios is None:
        return np.zeros((m, m))
    z = np.asarray(ratios, dtype=float).reshape(-1)
    if z.size != m or not np.all(np.isfinite(z)) or np.any(z < 0):
        raise ConfigError(f"link '{link}': damping.ratios: expected {m} finite values >= 0, "
                          f"got {np.asarray(ratios).tolist()}")
    w2, W = sla.eigh(K, Mm)  # W^T Mm W = 1
    order = np.argsort(w2)
    w, W = np.sqrt(np.clip(w2[order], 0.0, None)), W[:, order]
    MW = Mm @ W
    return MW @ np.diag(2.0 * z * w) @ MW.T


def body_from_reduced(reduced, modes: Sequence[int] | None = None, *, damping_ratios=None,
                      rayleigh=None, second_order: bool = False, plane: str | None = None
                      ) -> BodyMass:
    """BodyMass of a ReducedLink keeping ``modes`` (indices, default all).

    Parameters
    ----------
    reduced : ReducedLink.
    modes : kept mode indices (0-based), e.g. ``range(2)``.
    damping_ratios : (k,) ratio per kept mode, ordered by frequency.
    rayleigh : (alpha, beta) Rayleigh coefficients (1/s, s).
    second_order : the second-order mass moments (a link reduced with geometric
        stiffening; none if the artifact has none): the link's accelerations, spin and
        gravity stiffen its modes (:func:`pipeline.dynamics.mass_matrix.link_terms`).
    plane : "xy", "yz" or "xz": a planar link, whose mass keeps no second-order motion
        out of its plane (as its frames, :func:`frame_views`).
    """
    idx = select_modes(reduced.n_modes, modes, reduced.name)
    K = reduced.modal_stiffness[np.ix_(idx, idx)]
    Mm = reduced.modal_mass[np.ix_(idx, idx)]
    D = modal_damping(K, Mm, ratios=damping_ratios, rayleigh=rayleigh, link=reduced.name)
    G = reduced.second_order_moments(idx) if second_order and len(idx) else None
    if G is not None and plane is not None:
        G[..., _plane(plane)[0]] = 0.0
    return BodyMass(C=np.array(reduced.C, dtype=float), Cp=reduced.Cp[idx].copy(),
                    Cpp=reduced.Cpp[np.ix_(idx, idx)].copy(), stiffness=K.copy(), damping=D,
                    second_order_moments=np.zeros((0, 0, 4, 3)) if G is None else G)


class FrameView:
    """A frame as :func:`pipeline.kinematics.links.link_from_frames` takes it: name, pose
    (4, 4), phi, psi (k, 3) and hess (k, k, 3) or None."""

    def __init__(self, name, pose, phi, psi, hess=None):
        self.name, self.pose, self.phi, self.psi, self.hess = name, pose, phi, psi, hess


def frame_views(reduced, idx, plane: str | None = None, second_order: bool = False,
                extra=None, where: str | None = None) -> list[FrameView]:
    """The reduced link's frames restricted to the kept modes ``idx``: with their
    second-order translations (``second_order``, geometric stiffening; None if the
    artifact has none), the reference's rotation left out under a chord reference (its
    frame is the chord's, a pin), plus the ``extra`` frames ``{name: (frame it is fixed
    on, local pose (4, 4))}``, all projected on ``plane`` last.

    An extra frame is attached to the 3-D motion of its base, first order like the shape
    matrix: its origin moves by phi + psi x (R0 d) for the local offset d, it turns by
    psi, and it takes the base's second-order translation. Attached before the projection,
    a point off the plane keeps the in-plane motion the base's out-of-plane rotation
    gives it, as the mode shape does. ``where`` names the extra frames in messages
    (default ``link '<name>': frames``).
    """
    where = f"link '{reduced.name}': frames" if where is None else where
    H = reduced.frame_hessians(idx) if second_order and len(idx) else None
    # without a plane, each mode's own plane (an asymmetric mesh's round-off across it
    # would let a planar loop's out-of-plane rows lock the mode)
    planes = link_mode_planes(reduced, idx) if plane is None else ((),) * len(idx)
    views = {}
    for i, f in enumerate(reduced.frames):
        phi, psi = without_plane_round_off(np.array(f.phi)[list(idx)],
                                           np.array(f.psi)[list(idx)], planes)
        if reduced.chord is not None and i == 0:
            psi = np.zeros_like(psi)
        hess = None if H is None else _without_pair_round_off(H[i].copy(), planes)
        views[f.name] = FrameView(f.name, np.array(f.pose, dtype=float), phi, psi, hess)
    for new, (on, local) in (extra or {}).items():
        if on not in views:
            raise ConfigError(f"{where}.{new}.on: expected one of {sorted(views)}, "
                              f"got {on!r}")
        local = np.asarray(local, dtype=float)
        if local.shape != (4, 4):
            raise ConfigError(f"{where}.{new}: expected a (4, 4) pose, got shape "
                              f"{local.shape}")
        base = views[on]
        views[new] = FrameView(new, base.pose @ local,
                               base.phi + np.cross(base.psi, base.pose[:3, :3] @ local[:3, 3]),
                               base.psi.copy(), None if base.hess is None else base.hess.copy())
    if plane is not None:  # the planar loops cannot follow residual out-of-plane motion
        for v in views.values():
            v.phi, v.psi = project_on_plane(v.phi, v.psi, plane)
            if v.hess is not None:
                v.hess[..., _plane(plane)[0]] = 0.0
    return list(views.values())


def _without_pair_round_off(hess: np.ndarray, planes) -> np.ndarray:
    """A frame's second-order translations (k, k, 3) without the part across a plane both
    modes of a pair move in (:func:`link_mode_planes`)."""
    for a, pa in enumerate(planes):
        for b, pb in enumerate(planes):
            for plane in set(pa) & set(pb):
                hess[a, b, PLANES[plane][0]] = 0.0
    return hess


def link_from_reduced(reduced, modes: Sequence[int] | None = None, name: str | None = None,
                      frames=None, plane: str | None = None, second_order: bool = False
                      ) -> Link:
    """Kinematics Link with the ReducedLink's frames and the kept modes' phi/psi.

    Parameters
    ----------
    reduced : ReducedLink.
    modes : kept mode indices (default all; :func:`in_plane_modes` for a planar loop).
    name : link name (default the reduced link's).
    frames : optional ``{new_name: (existing_frame, local pose (4, 4))}``: extra
        frames rigidly attached to existing ones (e.g. a pin axis across a
        bar whose interface frame has z along the bar).
    plane : "xy", "yz" or "xz": the frames' modal motion projected on that plane of the
        body frame (:func:`project_on_plane`), as for a planar loop.
    second_order : the frames' second-order translations (a link reduced with geometric
        stiffening): the forces at them stiffen its modes (:func:`frame_views`).
    """
    idx = select_modes(reduced.n_modes, modes, reduced.name)
    return link_from_frames(name or reduced.name,
                            frame_views(reduced, idx, plane, second_order, frames))
