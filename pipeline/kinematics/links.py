"""Links, their named frames, and rigid/flexible shape matrices (DESIGN §3).

A link has a body frame (its reference interface; for a flexible link the
frame where its modes are clamped) and named frames given by their pose S0
(4, 4) in the body frame. A flexible link adds, per frame, the modal
translations phi (m, 3) [m per unit eta] and small rotations psi (m, 3)
[rad per unit eta] of the frame, in the body frame. The shape matrix is first
order in the modal coordinates eta (m,):

    S(eta) = [[(1 + [theta]x) R0, r0 + u], [0, 1]],
    u = sum_a eta_a phi_a,  theta = sum_a eta_a psi_a,

so S is *linear* in eta: S(eta) = S0 + sum_a eta_a S_a with the constant
dS/deta_a = S_a = [[[psi_a]x R0, phi_a], [0, 0]]. The rigid link is m = 0.
(The rotation block is not exactly orthogonal at finite eta: O(eta^2), as in
the dissertation; the dynamics invariants rely on the linearity.)

Every link gets a frame named ``"body"`` (identity pose, no modal motion)
unless the user gives one.

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics.rotations import translation
>>> bar = flexible_link("bar", {"tip": (translation([1.0, 0, 0]), [[0, 0.1, 0]], [[0, 0, 0.2]])})
>>> S = bar.frame("tip").shape([0.5])
>>> bool(np.allclose(S[:3, 3], [1.0, 0.05, 0.0]) and np.isclose(S[1, 0], 0.1))
True
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import validate_array
from pipeline.kinematics.rotations import skew

__all__ = ["BODY", "Frame", "Link", "flexible_link", "link_from_frames", "rigid_link"]

BODY = "body"


@dataclass(frozen=True)
class Frame:
    """Named frame on a link.

    Attributes
    ----------
    name : str
    pose : (4, 4) undeformed pose S0 in the body frame (rotation orthonormal, m).
    phi : (m, 3) modal translations of the frame origin, m per unit eta.
    psi : (m, 3) modal small rotations of the frame, rad per unit eta.
    hess : (m, m, 3) second derivatives of the origin's translation, d2r/deta_a deta_b, m
        per unit eta^2 (symmetric in a, b), or None (first order). A link loaded along
        its length shortens its chord as it bends: the second-order translation of a
        frame is what makes the forces acting there -- applied or transmitted by a joint
        -- stiffen (tension) or soften (compression) the modes, conservatively
        (``ReducedLink.frame_hessians``).
    """

    name: str
    pose: np.ndarray
    phi: np.ndarray
    psi: np.ndarray
    hess: np.ndarray | None = None
    dshape: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        dS = np.zeros((self.n_modes, 4, 4))
        for a in range(self.n_modes):
            dS[a, :3, :3] = skew(self.psi[a]) @ self.pose[:3, :3]
            dS[a, :3, 3] = self.phi[a]
        for arr in (self.pose, self.phi, self.psi, dS):
            arr.setflags(write=False)
        object.__setattr__(self, "dshape", dS)
        if self.hess is not None:
            H = np.array(self.hess, dtype=float)
            if H.shape != (self.n_modes, self.n_modes, 3):
                raise ConfigError(f"frame '{self.name}': hess: expected shape "
                                  f"{(self.n_modes, self.n_modes, 3)}, got {H.shape}")
            H = 0.5 * (H + H.transpose(1, 0, 2))
            H.setflags(write=False)
            object.__setattr__(self, "hess", H if np.any(H) else None)

    @property
    def n_modes(self) -> int:
        return self.phi.shape[0]

    @property
    def is_constant(self) -> bool:
        """True when the frame does not move with the modal coordinates."""
        return not (np.any(self.phi) or np.any(self.psi))

    def shape(self, eta=()) -> np.ndarray:
        """(4, 4) shape matrix S(eta); eta (m,) modal coordinates."""
        if self.n_modes == 0:
            return self.pose
        m = self.n_modes  # a (m,) @ (m, 16) product: tensordot's overhead dominates at 4x4
        eta = np.asarray(eta, dtype=float)
        S = self.pose + (eta @ self.dshape.reshape(m, 16)).reshape(4, 4)
        if self.hess is not None:
            S[:3, 3] += 0.5 * np.einsum("a,abi,b->i", eta, self.hess, eta)
        return S

    def shape_derivatives(self, eta=None) -> np.ndarray:
        """(m, 4, 4) dS/deta_a at eta (constant for a first-order frame)."""
        if self.hess is None or eta is None:
            return self.dshape
        dS = self.dshape.copy()
        dS[:, :3, 3] += np.einsum("abi,b->ai", self.hess, np.asarray(eta, dtype=float))
        return dS

    def shape_acceleration(self, eta_d) -> np.ndarray | None:
        """(4, 4) S'' at eta'' = 0: the second-order translation's eta'^T H eta' (None for a
        first-order frame)."""
        if self.hess is None:
            return None
        S = np.zeros((4, 4))
        S[:3, 3] = np.einsum("a,abi,b->i", eta_d, self.hess, eta_d)
        return S


@dataclass(frozen=True)
class Link:
    """A rigid (n_modes == 0) or flexible link with its named frames."""

    name: str
    frames: tuple[Frame, ...]
    n_modes: int = 0

    def __post_init__(self):
        names = [f.name for f in self.frames]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f"link '{self.name}': frames: duplicate frame name(s) {dup}")
        for f in self.frames:
            if f.n_modes != self.n_modes:
                raise ConfigError(f"link '{self.name}': frame '{f.name}': expected "
                                  f"{self.n_modes} modes, got {f.n_modes}")

    @property
    def is_flexible(self) -> bool:
        return self.n_modes > 0

    def frame(self, name: str) -> Frame:
        """The frame called ``name``; ConfigError listing the frames otherwise."""
        for f in self.frames:
            if f.name == name:
                return f
        raise ConfigError(f"link '{self.name}': frame '{name}' does not exist; "
                          f"frames: {[f.name for f in self.frames]}")


def _pose(value, where: str) -> np.ndarray:
    H = validate_array(value, (4, 4), where).copy()
    R = H[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
        raise ConfigError(f"{where}: expected a rigid pose (orthonormal rotation, det +1)")
    if np.abs(H[3] - [0.0, 0.0, 0.0, 1.0]).max() > 0:
        raise ConfigError(f"{where}: expected last row [0, 0, 0, 1], got {H[3].tolist()}")
    return H


def _make_frame(link: str, name: str, pose, phi, psi, m: int, hess=None) -> Frame:
    where = f"link '{link}': frame '{name}'"
    H = _pose(pose, f"{where}: pose")
    phi = validate_array(np.zeros((m, 3)) if phi is None else phi, (m, 3), f"{where}: phi").copy()
    psi = validate_array(np.zeros((m, 3)) if psi is None else psi, (m, 3), f"{where}: psi").copy()
    if hess is not None:
        hess = validate_array(hess, (m, m, 3), f"{where}: hess").copy()
    return Frame(name, H, phi, psi, hess)


def _with_body(link: str, frames: list[Frame], m: int) -> tuple[Frame, ...]:
    if not any(f.name == BODY for f in frames):
        frames = [Frame(BODY, np.eye(4), np.zeros((m, 3)), np.zeros((m, 3)))] + frames
    return tuple(frames)


def rigid_link(name: str, frames: Mapping[str, np.ndarray] | None = None) -> Link:
    """Rigid link with frames ``{name: pose (4, 4) in the body frame}``."""
    fr = [_make_frame(name, k, v, None, None, 0) for k, v in (frames or {}).items()]
    return Link(name, _with_body(name, fr, 0), 0)


def flexible_link(name: str, frames: Mapping[str, tuple]) -> Link:
    """Flexible link with frames ``{name: (pose (4, 4), phi (m, 3), psi (m, 3)[, hess
    (m, m, 3)])}``.

    All frames must have the same number of modes m >= 1 (the body frame has
    phi = psi = 0 by construction).
    """
    ms = {np.shape(v[1])[0] if np.ndim(v[1]) == 2 else -1 for v in frames.values()}
    if len(ms) != 1 or min(ms) < 1:
        raise ConfigError(f"link '{name}': frames: expected phi/psi of shape (m, 3) with the "
                          f"same m >= 1 for every frame, got m in {sorted(ms)}")
    m = ms.pop()
    fr = [_make_frame(name, k, v[0], v[1], v[2], m, v[3] if len(v) > 3 else None)
          for k, v in frames.items()]
    return Link(name, _with_body(name, fr, m), m)


def link_from_frames(name: str, frames: Iterable) -> Link:
    """Link from objects with ``name``, ``pose``, ``phi``, ``psi`` and optionally ``hess``
    (e.g. a reduced link's frames).

    With zero modes the link is rigid.
    """
    frames = list(frames)
    if not frames:
        return rigid_link(name)
    m = int(np.shape(frames[0].phi)[0])
    fr = [_make_frame(name, f.name, f.pose, f.phi, f.psi, m, getattr(f, "hess", None))
          for f in frames]
    return Link(name, _with_body(name, fr, m), m)
