"""Constraint rank, redundant rows, DOF and the choice of independent coordinates.

All decisions are taken on a dimensionless Jacobian: position rows divided
by the mechanism's length scale, then every column divided by its norm (so
radians, metres and modal amplitudes compete fairly).

- Rank: singular values above ``RANK_RTOL`` times the largest (SVD).
- Independent constraint rows: QR with column pivoting of J^T; the rows left
  out are *redundant* (named, e.g. "L1 (cut 'D'): position z" for a planar
  loop built in 3D).
- Dependent coordinates: prescribed coordinates (drivers, every modal
  coordinate) are independent by definition; among the others, QR with column
  pivoting of the selected rows picks the best-conditioned square dependent
  block; the rest are *free* independent coordinates (remaining DOF).
- Passive (idle) motions: directions of the remaining null space that move
  one loop link and no other link, e.g. the spin of an S-S coupler about its
  own axis in an RSSR linkage.

Examples
--------
>>> import numpy as np
>>> J = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
>>> numerical_rank(J)
2
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from pipeline.kinematics.closure import closure, row_weights
from pipeline.kinematics.failures import SingularConfigurationError
from pipeline.kinematics.mechanism import Mechanism

__all__ = ["RANK_RTOL", "ZERO_COLUMN", "DofReport", "HeldMode", "Partition", "PassiveMotion",
           "dof_report", "held_modes", "normalised_jacobian", "numerical_rank",
           "select_partition"]

#: Relative singular-value threshold of the rank decisions.
RANK_RTOL = 1e-8


@dataclass(frozen=True)
class Partition:
    """Split of the coordinates for position, velocity and acceleration analysis.

    Attributes
    ----------
    rows : (r,) independent closure rows (r = rank).
    dependent : (r,) coordinate indices solved from the closure equations.
    prescribed : driven and modal coordinate indices.
    free : remaining independent coordinate indices (held by the caller).
    rcond : smallest / largest singular value of the normalised dependent block
        when it was selected.
    secondary : coordinates preferred independent (the modal ones): dependent only where
        the others cannot satisfy the loops (a planar loop's flexible link keeping
        out-of-plane modes); independent ones among them are in ``free``.
    """

    rows: np.ndarray
    dependent: np.ndarray
    prescribed: np.ndarray
    free: np.ndarray
    rcond: float
    secondary: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def independent(self) -> np.ndarray:
        return np.concatenate([self.prescribed, self.free]).astype(int)


@dataclass(frozen=True)
class PassiveMotion:
    """An idle motion: link ``link`` moves alone (rotation axis through
    ``point`` along ``direction``, ground axes, m) with these coordinates."""

    link: str
    coordinates: tuple[str, ...]
    point: np.ndarray
    direction: np.ndarray


@dataclass(frozen=True)
class DofReport:
    """Mobility at one configuration.

    ``dof`` = n - rank counts every coordinate (joint and modal);
    ``free`` are the independent coordinates left once drivers and modal
    coordinates are prescribed; ``passive`` the idle motions among them.
    """

    n_coordinates: int
    rank: int
    dof: int
    redundant: tuple[str, ...]
    prescribed: tuple[str, ...]
    dependent: tuple[str, ...]
    free: tuple[str, ...]
    passive: tuple[PassiveMotion, ...]

    @property
    def effective_dof(self) -> int:
        """DOF without the passive motions."""
        return self.dof - len(self.passive)

    def summary(self) -> str:
        lines = [(f"coordinates {self.n_coordinates}, independent constraints {self.rank}, "
                  f"DOF {self.dof} ({len(self.passive)} passive)"),
                 f"free after drivers/modes: {list(self.free)}"]
        if self.redundant:
            lines.append(f"redundant constraints: {list(self.redundant)}")
        for p in self.passive:
            lines.append(f"passive: link '{p.link}' spins about axis {np.round(p.direction, 6)} "
                         f"through {np.round(p.point, 6)} ({', '.join(p.coordinates)})")
        return "\n".join(lines)


#: A weighted Jacobian column smaller than this in its coordinate's natural units
#: (:attr:`Mechanism.coordinate_units`) is round-off: the coordinate does not move the loops.
ZERO_COLUMN = 1e-10


def normalised_jacobian(mech: Mechanism, J: np.ndarray,
                        columns: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Row-weighted, column-normalised J and the column scales c (J_n = W J / c).

    Columns whose weighted norm is below ZERO_COLUMN in their coordinate's natural units are
    not normalised (c = 1 / unit): a rotation about an axis that moves the loops rigidly
    (a slewing base under a planar loop) has an analytically zero column, and scaling its
    1e-17 round-off up to a unit column would invent a constraint direction. ``columns``:
    the coordinates of J's columns when J holds only some of them.
    """
    Jw = row_weights(mech)[:, None] * J
    unit = mech.coordinate_units if columns is None else mech.coordinate_units[columns]
    c = np.linalg.norm(Jw, axis=0)
    tiny = c * unit <= ZERO_COLUMN
    c[tiny] = 1.0 / unit[tiny]
    return Jw / c, c


def numerical_rank(J: np.ndarray, rtol: float = RANK_RTOL) -> int:
    """Number of singular values of J above rtol times the largest."""
    if J.size == 0:
        return 0
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > rtol * s[0])) if s[0] > 0 else 0


def _pivots(B: np.ndarray) -> np.ndarray:
    """Column order of QR with column pivoting of B, with near-ties going to the earlier
    column: columns of equal norm are common (symmetric linkages, normalised columns),
    and the choice must not hang on rounding (BLAS, evaluation order)."""
    tie = 1.0 - 1e-9 * np.arange(B.shape[1])
    return sla.qr(B * tie, mode="r", pivoting=True)[1]


def _independent_rows(Jn: np.ndarray, rank: int) -> np.ndarray:
    if rank == 0:
        return np.zeros(0, dtype=int)
    return np.sort(_pivots(Jn.T)[:rank])


def _null_vectors(B: np.ndarray, rtol: float = RANK_RTOL, atol: float = 0.0) -> np.ndarray:
    """(cols, k) orthonormal basis of the numerical null space of B.

    Singular values at or below max(rtol * s_max, atol) count as zero.
    """
    if B.shape[0] == 0:
        return np.eye(B.shape[1])
    _, s, Vt = np.linalg.svd(B)
    r = int(np.sum(s > max(rtol * s[0], atol))) if s.size else 0
    return Vt[r:].T


def singular_joints(mech: Mechanism, B: np.ndarray, cand: np.ndarray,
                    expected_rank: int) -> tuple[str, ...]:
    """Joints whose variables move along the directions in which the block B
    (all closure rows x candidate coordinates) has lost rank below ``expected_rank``."""
    _, s, Vt = np.linalg.svd(B)
    now = int(np.sum(s > RANK_RTOL * s[0])) if s.size and s[0] > 0 else 0
    lost = Vt[min(now, expected_rank - 1):expected_rank]
    # fewer candidate columns than constraints: every candidate is implicated
    weight = np.abs(lost).max(axis=0) if lost.size else np.ones(cand.size)
    names = []
    for i in cand[weight > 0.1 * weight.max()]:
        j = mech.joint_of(int(i)) or mech.coordinates[i]
        if j not in names:
            names.append(j)
    return tuple(names)


def _dependent(B: np.ndarray, rank: int, primary: np.ndarray) -> np.ndarray:
    """Positions of ``rank`` columns of B for the dependent block: the best-conditioned
    among the ``primary`` ones (a boolean mask), completed with the best of the others for
    the directions the primary columns cannot span."""
    prim, sec = np.flatnonzero(primary), np.flatnonzero(~primary)
    if not sec.size or not prim.size:
        order = prim if prim.size else sec
        return order[_pivots(B[:, order])[:rank]] if rank else order[:0]
    Bp = B[:, prim]
    rp = min(numerical_rank(Bp), rank)
    chosen = prim[_pivots(Bp)[:rp]] if rp else prim[:0]
    if rp < rank:
        Q = np.linalg.qr(B[:, chosen])[0] if chosen.size else np.zeros((B.shape[0], 0))
        rest = B[:, sec] - Q @ (Q.T @ B[:, sec])
        chosen = np.concatenate([chosen, sec[_pivots(rest)[:rank - rp]]])
    return chosen


def select_partition(mech: Mechanism, J: np.ndarray, prescribed, *, t: float | None = None,
                     drivers: dict[str, float] | None = None, q: np.ndarray | None = None,
                     expected_rank: int | None = None, rcond_min: float = RANK_RTOL,
                     secondary=None) -> Partition:
    """Choose independent rows and the best-conditioned dependent coordinates.

    Parameters
    ----------
    J : (6 k, n) closure Jacobian at the configuration.
    prescribed : indices of the held coordinates (drivers; the modal ones too when
        ``secondary`` is None).
    secondary : coordinates made dependent only where the others cannot satisfy the loops
        (default none: pass the modal coordinates here instead of in ``prescribed`` to let
        the loops constrain a flexible link's out-of-plane modes).
    t, drivers, q : context reported if the configuration is singular.
    expected_rank : the number of independent constraints established at
        assembly; fewer here is a singular configuration (e.g. a bifurcation).
    rcond_min : smallest acceptable rcond of the normalised dependent block.

    Raises
    ------
    SingularConfigurationError
        The non-prescribed columns cannot span the constraints (rank lost), or
        the constraints themselves lost rank.
    """
    prescribed = np.unique(np.asarray(prescribed, dtype=int))
    sec = np.zeros(0, dtype=int) if secondary is None else np.setdiff1d(
        np.asarray(secondary, dtype=int), prescribed)
    Jn, _ = normalised_jacobian(mech, J)
    rank = numerical_rank(Jn)
    rows = _independent_rows(Jn, rank)
    cand = np.setdiff1d(np.arange(mech.n), prescribed)
    B = Jn[rows][:, cand]
    r_exp = rank if expected_rank is None else expected_rank
    if rank == 0 and r_exp == 0:
        return Partition(rows, np.zeros(0, dtype=int), prescribed, cand, 1.0, sec)
    if cand.size >= rank:
        dep = np.sort(cand[_dependent(B, rank, ~np.isin(cand, sec))]) if rank else cand[:0]
    else:
        dep = cand
    s = np.linalg.svd(Jn[rows][:, dep], compute_uv=False) if dep.size else np.zeros(1)
    rc = float(s[-1] / s[0]) if dep.size == rank and s[0] > 0 else 0.0
    if rc < rcond_min or rank < r_exp:
        joints = singular_joints(mech, Jn[:, cand], cand, r_exp) if cand.size else ()
        where = "" if t is None else f" at t = {t:.6g} s"
        drv = "" if not drivers else " with " + ", ".join(f"{k} = {v:.6g}"
                                                          for k, v in drivers.items())
        what = (f"the constraints lost rank ({rank} < {r_exp})" if rank < r_exp else
                f"the closure Jacobian of the non-prescribed coordinates lost rank "
                f"(rcond {rc:.2e})")
        raise SingularConfigurationError(
            f"singular configuration{where}{drv}: {what}; joints losing rank: {list(joints)}",
            joints, q if q is not None else np.full(mech.n, np.nan), t, drivers, rc)
    return Partition(rows, dep, prescribed, np.setdiff1d(cand, dep), rc, sec)


def _passive(mech: Mechanism, tree, Nq: np.ndarray) -> tuple[PassiveMotion, ...]:
    """Idle motions among the motions Nq (n, d) allowed by closure and drivers."""
    if Nq.shape[1] == 0 or not mech.topology.loops:
        return ()
    ground = mech.link_index(mech.ground)
    in_loops = sorted({l for lp in mech.topology.loops for l in lp.links} - {ground})
    moving = {l: np.einsum("nij,nd->ijd", tree.dA[l, :, :3, :], Nq).reshape(12, -1)
              for l in range(len(mech.links)) if l != ground}
    scale = max(np.abs(np.vstack(list(moving.values()))).max(), 1e-300)
    out = []
    for l in in_loops:
        others = np.vstack([M for k, M in moving.items() if k != l] or [np.zeros((0, Nq.shape[1]))])
        Z = _null_vectors(others / scale, atol=RANK_RTOL)
        for z in Z.T:
            qd = Nq @ z
            W = np.einsum("nij,n->ij", tree.dA[l], qd)
            if np.abs(W).max() < 1e-6 * scale:
                continue
            A = tree.A[l]
            Om = W[:3, :3] @ A[:3, :3].T
            w = np.array([Om[2, 1], Om[0, 2], Om[1, 0]])
            v = W[:3, 3] - Om @ A[:3, 3]
            d = w / np.linalg.norm(w)
            point = np.cross(w, v) / (w @ w)
            coords = tuple(mech.coordinates[i] for i in np.flatnonzero(np.abs(qd) > 1e-6 *
                                                                          np.abs(qd).max()))
            out.append(PassiveMotion(mech.links[l].name, coords, point, d))
    return tuple(out)


@dataclass(frozen=True)
class HeldMode:
    """A combination of a link's modal coordinates the loops hold at zero.

    ``coordinates`` are the link's modal coordinates in it (largest share first),
    ``row`` the closure row that holds it most (e.g. "L1 (cut 'T'): position z").
    """

    link: str
    coordinates: tuple[str, ...]
    row: str


def held_modes(mech: Mechanism, q: np.ndarray, driven=()) -> tuple[HeldMode, ...]:
    """The modal motions the loops hold at q (n,), drivers ``driven`` (names) held.

    A flexible link's modal columns of the normalised closure Jacobian, less what the
    joint coordinates can take up, span the rows no joint can follow: a motion of the
    modes along them cannot happen, so those modes (or combinations) are dependent and
    stay at zero (:func:`select_partition` makes them so). Each is named by its link, its
    main coordinates and its main row. Round-off across a plane the modes move in is gone
    before this (:mod:`pipeline.invariants.planar_modes`); what is left is a real hold.
    """
    if not mech.topology.loops or not mech.modal_coordinates.size:
        return ()
    q = np.asarray(q, dtype=float)
    Jn, _ = normalised_jacobian(mech, closure(mech, q).J)
    others = np.setdiff1d(np.arange(mech.n), np.union1d(mech.indices(list(driven)),
                                                        mech.modal_coordinates)).astype(int)
    Jo = Jn[:, others]
    U = _null_vectors(Jo.T) if others.size else np.eye(Jn.shape[0])  # rows joints cannot follow
    names = mech.row_names()
    out = []
    for link, idx in zip(mech.links, mech.modal_index):
        if not len(idx):
            continue
        B = U.T @ Jn[:, idx]  # the modal columns on those rows
        Ub, s, Vt = np.linalg.svd(B, full_matrices=False)
        for k in np.flatnonzero(s > RANK_RTOL):
            rows = U @ Ub[:, k]
            v = np.abs(Vt[k])
            order = np.argsort(-v)
            coords = tuple(mech.coordinates[idx[i]] for i in order if v[i] >= 0.1 * v.max())
            out.append(HeldMode(link.name, coords, names[int(np.argmax(np.abs(rows)))]))
    return tuple(out)


def dof_report(mech: Mechanism, q: np.ndarray, driven=()) -> DofReport:
    """DOF, redundant constraints, free coordinates and passive motions at q.

    Parameters
    ----------
    q : (n,) an assembled configuration (closure satisfied).
    driven : names of driven coordinates. Modal coordinates count as prescribed unless the
        loops constrain them (then they are listed among the dependent ones).
    """
    q = np.asarray(q, dtype=float)
    c = closure(mech, q)
    modal = mech.modal_coordinates
    part = select_partition(mech, c.J, mech.indices(driven), q=q, secondary=modal)
    Jn, col = normalised_jacobian(mech, c.J)
    names = mech.row_names()
    redundant = tuple(names[i] for i in np.setdiff1d(np.arange(len(names)), part.rows))
    held = np.union1d(part.prescribed, np.setdiff1d(modal, part.dependent)).astype(int)
    cand = np.setdiff1d(np.arange(mech.n), np.union1d(held, modal))
    Nq = np.zeros((mech.n, 0))
    if cand.size:
        Nc = _null_vectors(Jn[part.rows][:, cand]) if part.rows.size else np.eye(cand.size)
        Nq = np.zeros((mech.n, Nc.shape[1]))
        Nq[cand] = Nc / col[cand, None]
    cn = mech.coordinates
    return DofReport(mech.n, len(part.rows), mech.n - len(part.rows), redundant,
                     tuple(cn[i] for i in held), tuple(cn[i] for i in part.dependent),
                     tuple(cn[i] for i in np.setdiff1d(part.free, modal)),
                     _passive(mech, c.tree, Nq))
