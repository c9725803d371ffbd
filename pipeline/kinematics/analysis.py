"""Position, velocity and acceleration analysis of a closed-loop mechanism.

Position: Newton on the independent closure rows for the dependent
coordinates (the square block chosen by :func:`select_partition`), with a
backtracking line search on the weighted residual norm; if Newton stalls, a
trust-region least-squares search over every non-prescribed coordinate takes
over. It either closes the loops (then a final Newton polish) or stops at
the closest configuration, reported in a :class:`ClosureError` that names the
loop with the largest residual.

Velocity: J_d q'_d = -J_i q'_i. Acceleration: J_d q''_d = gamma - J_i q''_i
(rows: the independent closure rows; i: prescribed + free coordinates).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics.links import rigid_link
>>> from pipeline.kinematics.joints import Joint
>>> from pipeline.kinematics.mechanism import build_mechanism
>>> from pipeline.kinematics.rotations import translation
>>> T = translation
>>> m = build_mechanism([
...     rigid_link("ground", {"D": T([2, 0, 0])}), rigid_link("crank", {"B": T([1, 0, 0])}),
...     rigid_link("coupler", {"C": T([2, 0, 0])}), rigid_link("rocker", {"C": T([2, 0, 0])})], [
...     Joint("A", "revolute", "ground", "body", "crank", "body", (1.57,)),
...     Joint("B", "revolute", "crank", "B", "coupler", "body", (-1.0,)),
...     Joint("C", "revolute", "coupler", "C", "rocker", "C", (-1.5,)),
...     Joint("D", "revolute", "rocker", "body", "ground", "D", (-1.0,))])
>>> a = assemble(m, driven=["A.theta"])
>>> float(np.abs(a.closure.r).max()) < 1e-12
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from pipeline.core.errors import ConfigError, KinematicsError
from pipeline.kinematics.closure import ClosureValue, closure, closure_residual, row_weights
from pipeline.kinematics.failures import ClosureError, SingularConfigurationError
from pipeline.kinematics.mechanism import ROW_COMPONENTS, Mechanism
from pipeline.kinematics.partition import (
    Partition,
    normalised_jacobian,
    numerical_rank,
    select_partition,
)

__all__ = ["Assembly", "assemble", "solve_acceleration", "solve_position", "solve_velocity"]


@dataclass(frozen=True)
class Assembly:
    """An assembled configuration.

    Attributes
    ----------
    q : (n,) coordinates satisfying closure.
    closure : residual, Jacobian and link poses at q.
    partition : coordinate split chosen at q.
    iterations : Newton (+ least-squares) iterations used.
    """

    q: np.ndarray
    closure: ClosureValue
    partition: Partition
    iterations: int


def _err(w: np.ndarray, r: np.ndarray) -> float:
    return float(np.abs(w * r).max()) if r.size else 0.0


def _newton(mech, q, part, w, tol, max_iter):
    """Damped Newton; returns (q, closure value, iterations, converged)."""
    c = closure(mech, q)
    rows, dep = part.rows, part.dependent
    f = float(np.sum((w * c.r) ** 2))
    for it in range(max_iter):
        if _err(w, c.r) <= tol:
            return q, c, it, True
        try:
            dx = np.linalg.solve(c.J[np.ix_(rows, dep)], -c.r[rows])
        except np.linalg.LinAlgError:
            return q, c, it, False
        alpha, accepted = 1.0, False
        while alpha >= 1.0 / 1024:
            qt = q.copy()
            qt[dep] += alpha * dx
            ct = closure(mech, qt) if alpha == 1.0 else None
            rt = ct.r if ct is not None else closure_residual(mech, qt)
            ft = float(np.sum((w * rt) ** 2))
            if ft <= (1.0 - 1e-4 * alpha) * f or _err(w, rt) <= tol:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            return q, c, it, False
        q, f = qt, ft
        c = ct if ct is not None else closure(mech, q)
    return q, c, max_iter, _err(w, c.r) <= tol


def _closest(mech, q, part, w, max_nfev, movable=None):
    """Least-squares minimum of |W r| over ``movable`` (default: the non-prescribed
    coordinates)."""
    cand = np.setdiff1d(np.arange(mech.n), part.prescribed) if movable is None else movable
    if not np.all(np.isfinite(q)):
        raise ClosureError(f"closure: the start has non-finite coordinates "
                           f"{[mech.coordinates[i] for i in np.flatnonzero(~np.isfinite(q))]}",
                           "-", "-", np.full(6, np.nan), q.copy())

    def full(x):
        qq = q.copy()
        qq[cand] = x
        return qq

    res = least_squares(lambda x: w * closure_residual(mech, full(x)), q[cand],
                        jac=lambda x: w[:, None] * closure(mech, full(x)).J[:, cand],
                        method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=max_nfev)
    return full(res.x), int(res.nfev)


def _closure_error(mech: Mechanism, q: np.ndarray, r: np.ndarray) -> ClosureError:
    w = row_weights(mech)
    per_loop = np.abs(w * r).reshape(-1, 6).max(axis=1)
    k = int(np.argmax(per_loop))
    lp = mech.topology.loops[k]
    rk = r[6 * k:6 * k + 6]
    worst = ROW_COMPONENTS[int(np.argmax(np.abs(w[6 * k:6 * k + 6] * rk)))]
    shown = ", ".join(f"{n} = {v:.6g}" for n, v in list(zip(mech.coordinates, q))[:12])
    more = " ..." if mech.n > 12 else ""
    cut = mech.joints[lp.cut].name
    joints = [mech.joints[j].name for j in lp.joints]
    msg = (f"loop '{lp.name}' (cut joint '{cut}', joints {joints}) cannot close: residual "
           f"|position| = {np.linalg.norm(rk[:3]):.3e} m, |rotation| = "
           f"{np.linalg.norm(rk[3:]):.3e} rad (largest: {worst}) at the closest configuration "
           f"found: {shown}{more}")
    return ClosureError(msg, lp.name, cut, r.copy(), q.copy())


def solve_position(mech: Mechanism, q_guess: np.ndarray, part: Partition, *, tol: float = 1e-12,
                   max_iter: int = 30, max_nfev: int = 400,
                   keep_free: bool = True) -> tuple[np.ndarray, ClosureValue, int]:
    """Close the loops for the dependent coordinates of ``part``.

    Parameters
    ----------
    q_guess : (n,) start; prescribed and free entries are kept (every one of them: a
        configuration the dependent coordinates cannot close is a ClosureError, never a
        silently moved independent coordinate).
    tol : closure tolerance on max |position| / length_scale and max |rotation|.
    keep_free : False lets the least-squares fallback move the free coordinates too (an
        approximate assembly, where only the prescribed ones are the user's).

    Returns
    -------
    q : (n,) closed configuration.
    closure : ClosureValue at q (with Jacobian).
    iterations : int

    Raises
    ------
    ClosureError
        No configuration within ``tol``: names the loop, its residual and the
        closest configuration found (``exc.q_closest``).
    """
    w = row_weights(mech)
    q = np.array(q_guess, dtype=float)
    q, c, it, ok = _newton(mech, q, part, w, tol, max_iter)
    if ok:
        return q, c, it
    movable = part.dependent if keep_free else np.setdiff1d(
        np.arange(mech.n), np.union1d(part.prescribed, np.setdiff1d(part.secondary,
                                                                     part.dependent)))
    q, nfev = _closest(mech, q, part, w, max_nfev, movable)
    q2, c, it2, ok = _newton(mech, q, part, w, tol, max_iter)
    if ok:
        return q2, c, it + nfev + it2
    r = closure_residual(mech, q)
    if _err(w, r) <= tol:  # closed by least squares; Newton's block is singular here
        return q, closure(mech, q), it + nfev
    if _err(w, r) <= 1e-6:  # closes, yet neither method converges: singular? (raises if so)
        select_partition(mech, closure(mech, q).J, part.prescribed, q=q,
                         expected_rank=len(part.rows))
    raise _closure_error(mech, q, r)


def solve_velocity(J: np.ndarray, part: Partition, qd: np.ndarray) -> np.ndarray:
    """(n,) rates with the dependent entries solved from J q' = 0 (independent ones kept)."""
    out = np.array(qd, dtype=float)
    R = J[part.rows]
    ind = part.independent
    out[part.dependent] = np.linalg.solve(R[:, part.dependent], -R[:, ind] @ out[ind])
    return out


def velocity_map(J: np.ndarray | None, part: Partition, columns, n: int) -> np.ndarray:
    """(n, k) dq/dx for x = q[columns], the dependent coordinates following the loops.

    Columns are any coordinates that are not dependent (independent, driven,
    modal); ``J`` may be None when ``part`` has no dependent coordinates (a tree).
    """
    columns = np.asarray(columns, dtype=int)
    B = np.zeros((n, columns.size))
    B[columns, np.arange(columns.size)] = 1.0
    if part.dependent.size:
        R = J[part.rows]
        B[part.dependent] = np.linalg.solve(R[:, part.dependent], -R[:, columns])
    return B


def solve_acceleration(J: np.ndarray, gamma: np.ndarray, part: Partition,
                       qdd: np.ndarray) -> np.ndarray:
    """(n,) accelerations with the dependent entries solved from J q'' = gamma."""
    out = np.array(qdd, dtype=float)
    R = J[part.rows]
    ind = part.independent
    out[part.dependent] = np.linalg.solve(R[:, part.dependent],
                                          gamma[part.rows] - R[:, ind] @ out[ind])
    return out


def _check_drivers(mech: Mechanism, J: np.ndarray, prescribed: np.ndarray, driven) -> None:
    """Raise if the prescribed coordinates leave fewer unknowns than constraints (decided on
    an assembled or closest configuration: an unclosed guess has spurious rank)."""
    Jn = normalised_jacobian(mech, J)[0]
    cand = np.setdiff1d(np.arange(mech.n), prescribed)
    rank, rank_c = numerical_rank(Jn), numerical_rank(Jn[:, cand])
    if rank_c < rank:
        raise KinematicsError(
            f"driven coordinates {list(driven)} over-constrain the mechanism: the other "
            f"coordinates can satisfy only {rank_c} of its {rank} independent closure "
            "constraints; drive fewer coordinates (see dof_report)")


def assemble(mech: Mechanism, q_guess: np.ndarray | None = None, driven=(), *,
             tol: float = 1e-12) -> Assembly:
    """Position analysis from the user's approximate assembly.

    Parameters
    ----------
    q_guess : (n,) start (default ``mech.q_initial``); driven entries are kept, modal ones
        too unless the loops constrain them (a planar loop's flexible link keeping
        out-of-plane modes: those become dependent coordinates).
    driven : names of the driven coordinates.

    Raises
    ------
    ClosureError
        The loops cannot be closed (see :func:`solve_position`).
    SingularConfigurationError
        The assembled configuration is singular for the given drivers.
    """
    q = np.array(mech.q_initial if q_guess is None else q_guess, dtype=float)
    if q.shape != (mech.n,) or not np.all(np.isfinite(q)):
        raise ConfigError(f"q_guess: expected {mech.n} finite values, got {q.shape} "
                          f"(finite: {bool(np.all(np.isfinite(q)))})")
    prescribed = np.unique(mech.indices(driven)).astype(int)
    modal = mech.modal_coordinates

    def partition(q, c):
        try:
            return select_partition(mech, c.J, prescribed, q=q, secondary=modal)
        except SingularConfigurationError:
            _check_drivers(mech, c.J, prescribed, driven)  # the clearer reason, if it is that
            raise

    try:
        part = select_partition(mech, closure(mech, q).J, prescribed, q=q, secondary=modal)
    except SingularConfigurationError:  # a poor guess may be singular: start least squares
        part = Partition(np.zeros(0, int), np.zeros(0, int), prescribed, np.zeros(0, int), 0.0,
                         modal)
        joints = np.setdiff1d(np.arange(mech.n), np.union1d(prescribed, modal))
        q, _ = _closest(mech, q, part, row_weights(mech), 400, joints)
        part = partition(q, closure(mech, q))
    q, c, it = solve_position(mech, q, part, tol=tol, keep_free=False)
    return Assembly(q, c, partition(q, c), it)
