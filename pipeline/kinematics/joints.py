"""Sheth-Uicker joints: 4x4 transforms of elementary motions along/about local axes.

A joint connects a frame on its *parent* link to a frame on its *child* link.
Its transform Phi(q) (4, 4) is the pose of the child frame in the parent frame;
at q = 0 the two frames coincide. Every joint type is a sequence of elementary
motions F_i = rot_a(q_i) or trans_a(q_i) applied in order (the first about/along
the parent frame's axis), so

    Phi(q) = F_1(q_1) F_2(q_2) ... F_n(q_n),
    dPhi/dq_k = P_k Q_k T_k = Phi (T_k^-1 Q_k T_k),

with P_k = F_1..F_k, T_k = F_k+1..F_n and Q_k the constant generator of the
k-th motion (``rotations.GENERATORS``). For one-variable joints and for the
last variable of a sequence (and for cylindrical, whose two motions share z)
the operator is the constant Q_k itself: dPhi/dq_k = Phi Q_k.

Types (:data:`JOINTS`), variables in order:

- ``revolute``: rot_z(theta)
- ``prismatic``: trans_z(d)
- ``cylindrical``: rot_z(theta) trans_z(d)
- ``universal`` (Cardan cross): rot_x(alpha) rot_y(beta); the shafts are the z
  axes of both frames, collinear at q = 0; the cross pins are parent x, child y.
- ``spherical``: rot_z(rz) rot_y(ry) rot_x(rx), angles measured from the
  assembled orientation (the joint's two frames coincide when assembled).
  Gimbal lock: the only singular set is |ry| = 90 deg. A relative rotation
  by an angle a from the assembled orientation has |sin ry| = |e_z . R e_x|
  <= sin a, so every orientation within a < 90 deg of the assembled one is
  reached with |ry| <= a: a working cone of +-60 deg keeps cos(ry) >= 0.5
  and the Jacobian well conditioned. Put the joint frames in the assembled
  (mid-range) orientation and the singular set stays 90 deg away.
- ``planar``: trans_x(x) trans_y(y) rot_z(theta) (motion in the local xy plane)
- ``fixed``: identity, no variable
- ``free``: trans_x trans_y trans_z rot_z rot_y rot_x (6 DOF; same angle
  convention and gimbal-lock statement as ``spherical``)

When the kinematic tree crosses a joint from child to parent it uses
Phi(q)^-1 = F_n(-q_n) ... F_1(-q_1): the same machinery with the motions
reversed and signs flipped (:attr:`JointType.reverse`).

Examples
--------
>>> import numpy as np
>>> rev = JOINTS["revolute"]
>>> Phi = rev.motion.transform([0.3])
>>> dPhi = rev.motion.derivatives([0.3])[0]
>>> np.allclose(dPhi, Phi @ rev.motion.generators[0])
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.kinematics.rotations import GENERATORS

__all__ = ["JOINTS", "Joint", "JointType", "MotionSequence"]

_I4 = np.eye(4)
_I4.setflags(write=False)


def elementary(kind: str, axis: int, x: float) -> np.ndarray:
    """(4, 4) rotation by x rad about (kind "R") or translation by x m along axis 0..2."""
    F = np.eye(4)
    if kind == "T":
        F[axis, 3] = x
        return F
    c, s = math.cos(x), math.sin(x)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    F[i, i] = c
    F[j, j] = c
    F[i, j] = -s
    F[j, i] = s
    return F


@dataclass(frozen=True)
class MotionSequence:
    """Product of elementary motions F_i(sign_i q_var_i), i = 0..n-1.

    Attributes
    ----------
    kinds : ("R" | "T", ...) rotation or translation per factor.
    axes : (int, ...) local axis 0, 1, 2 per factor.
    var : (int, ...) index of the joint variable driving each factor.
    signs : (float, ...) +1 or -1 per factor.
    """

    kinds: tuple[str, ...]
    axes: tuple[int, ...]
    var: tuple[int, ...]
    signs: tuple[float, ...]
    generators: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        gens = np.array([s * GENERATORS[(k, a)] for k, a, s in
                         zip(self.kinds, self.axes, self.signs)]).reshape(-1, 4, 4)
        object.__setattr__(self, "generators", gens)

    @property
    def n(self) -> int:
        return len(self.kinds)

    def reversed(self) -> MotionSequence:
        """The sequence of Phi(q)^-1 = F_n(-q_n) ... F_1(-q_1)."""
        return MotionSequence(self.kinds[::-1], self.axes[::-1], self.var[::-1],
                              tuple(-s for s in self.signs[::-1]))

    def factors(self, q) -> list[np.ndarray]:
        return [elementary(k, a, s * q[v]) for k, a, v, s in
                zip(self.kinds, self.axes, self.var, self.signs)]

    def transform(self, q) -> np.ndarray:
        """(4, 4) Phi(q); q (n,) in rad / m."""
        G = _I4
        for F in self.factors(q):
            G = G @ F
        return np.array(G)

    def derivatives(self, q) -> np.ndarray:
        """(n, 4, 4) dPhi/dq_k, ordered by variable index."""
        return self.evaluate(q)[1]

    def operators(self, q) -> np.ndarray:
        """(n, 4, 4) Q_k(q) with dPhi/dq_k = Phi Q_k(q) (constant for the last factor)."""
        Fs = self.factors(q)
        out = np.empty((self.n, 4, 4))
        T = _I4
        for i in range(self.n - 1, -1, -1):
            Ti = np.linalg.inv(T)
            out[self.var[i]] = Ti @ self.generators[i] @ T
            T = Fs[i] @ T
        return out

    def evaluate(self, q, qd=None):
        """Phi (4, 4), dPhi/dq (n, 4, 4) and, if qd is given, Phi_dot and Phi_ddot|q_ddot=0.

        Returns
        -------
        G, dG, Gd, Gdd : Gd = sum_k dG_k qd_k and Gdd = sum_kl d2G/dq_k dq_l qd_k qd_l
            (None when ``qd`` is None).
        """
        n = self.n
        if n == 0:
            return _I4, np.zeros((0, 4, 4)), (None if qd is None else np.zeros((4, 4))), \
                (None if qd is None else np.zeros((4, 4)))
        Fs = self.factors(q)
        if n == 1:  # fast path: revolute, prismatic
            F, Q = Fs[0], self.generators[0]
            dG = (F @ Q)[None]
            if qd is None:
                return F, dG, None, None
            w = qd[self.var[0]]
            return F, dG, dG[0] * w, (dG[0] @ Q) * (w * w)
        P = [_I4]
        for F in Fs:
            P.append(P[-1] @ F)
        T = [_I4] * (n + 1)
        for i in range(n - 1, -1, -1):
            T[i] = Fs[i] @ T[i + 1]
        dG = np.empty((n, 4, 4))
        for i in range(n):
            dG[self.var[i]] = P[i + 1] @ self.generators[i] @ T[i + 1]
        if qd is None:
            return P[n], dG, None, None
        # second-order recursion over the product: X_i+1 = X_i F_i
        X, Xd, Xdd = _I4, np.zeros((4, 4)), np.zeros((4, 4))
        for F, Q, v in zip(Fs, self.generators, self.var):
            Fd = F @ Q * qd[v]
            Fdd = Fd @ Q * qd[v]
            X, Xd, Xdd = X @ F, Xd @ F + X @ Fd, Xdd @ F + 2.0 * Xd @ Fd + X @ Fdd
        return P[n], dG, Xd, Xdd


def _seq(*motions: str) -> MotionSequence:
    kinds = tuple(m[0] for m in motions)
    axes = tuple("xyz".index(m[1]) for m in motions)
    return MotionSequence(kinds, axes, tuple(range(len(motions))), (1.0,) * len(motions))


@dataclass(frozen=True)
class JointType:
    """A joint type: its elementary motions and the names of its variables."""

    name: str
    variables: tuple[str, ...]
    motion: MotionSequence
    reverse: MotionSequence = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "reverse", self.motion.reversed())

    @property
    def n(self) -> int:
        return len(self.variables)


def _jt(name: str, variables: tuple[str, ...], *motions: str) -> JointType:
    return JointType(name, variables, _seq(*motions))


#: Joint types keyed by the YAML ``type:`` string.
JOINTS: dict[str, JointType] = {
    jt.name: jt
    for jt in (
        _jt("revolute", ("theta",), "Rz"),
        _jt("prismatic", ("d",), "Tz"),
        _jt("cylindrical", ("theta", "d"), "Rz", "Tz"),
        _jt("universal", ("alpha", "beta"), "Rx", "Ry"),
        _jt("spherical", ("rz", "ry", "rx"), "Rz", "Ry", "Rx"),
        _jt("planar", ("x", "y", "theta"), "Tx", "Ty", "Rz"),
        _jt("fixed", ()),
        _jt("free", ("x", "y", "z", "rz", "ry", "rx"), "Tx", "Ty", "Tz", "Rz", "Ry", "Rx"),
    )
}


@dataclass(frozen=True)
class Joint:
    """Description of one joint (no state).

    Parameters
    ----------
    name : str
    type : key of :data:`JOINTS`.
    parent, parent_frame : link and frame names of the parent side.
    child, child_frame : link and frame names of the child side.
    q0 : approximate assembly values of the joint variables (rad / m);
        default zeros (the two frames coincide).
    """

    name: str
    type: str
    parent: str
    parent_frame: str
    child: str
    child_frame: str
    q0: tuple[float, ...] = ()

    def __post_init__(self):
        if self.type not in JOINTS:
            raise ConfigError(f"joint '{self.name}': type: expected one of "
                              f"{sorted(JOINTS)}, got {self.type!r}")
        n = JOINTS[self.type].n
        q0 = tuple(float(x) for x in np.ravel(self.q0)) if len(self.q0) else (0.0,) * n
        if len(q0) != n or not all(math.isfinite(x) for x in q0):
            raise ConfigError(f"joint '{self.name}': q0: expected {n} finite value(s) for a "
                              f"{self.type} joint, got {self.q0!r}")
        object.__setattr__(self, "q0", q0)

    @property
    def kind(self) -> JointType:
        return JOINTS[self.type]


#: |cos ry| below which a spherical or free joint's z-y-x angles are at gimbal lock
GIMBAL_COS = 1e-6


def gimbal_locks(mech, q) -> list[str]:
    """One line per spherical or free joint whose z-y-x angles are at their singular set
    (|ry| = 90 deg, where rz and rx turn about the same axis) at q (n,): a legal pose at
    which the equations in these coordinates cannot be solved.

    >>> from pipeline.kinematics import build_mechanism, rigid_link
    >>> m = build_mechanism([rigid_link("ground"), rigid_link("b")],
    ...                     [Joint("S", "spherical", "ground", "body", "b", "body")])
    >>> gimbal_locks(m, [0.0, -np.pi / 2, 0.0])[0][:41]
    "joint 'S' (spherical) is at ry = -90 deg,"
    >>> gimbal_locks(m, [0.0, 0.5, 0.0])
    []
    """
    q = np.asarray(q, dtype=float)
    out = []
    for j in mech.joints:
        if j.type not in ("spherical", "free"):
            continue
        ry = float(q[mech.index(f"{j.name}.ry")])
        if abs(np.cos(ry)) < GIMBAL_COS:
            out.append(f"joint '{j.name}' ({j.type}) is at ry = {np.degrees(ry):.4g} deg, its "
                       "angles' singular set (gimbal lock: rz and rx turn about one axis); "
                       "assemble its two frames in the mid-range orientation of the motion "
                       "(the singular set is then 90 deg away)")
    return out


def gimbal_lock_note(mech, q) -> str:
    """"; <line>" for each joint of :func:`gimbal_locks` at q: what a failure message at a
    singular start adds ("" where none is)."""
    return "".join(f"; {w}" for w in gimbal_locks(mech, q))
