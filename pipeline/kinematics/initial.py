"""Consistent initial states: positions and velocities that satisfy the loops and the drivers,
honouring the values the user gave or saying by name which cannot be honoured.

Priorities (each a least-squares problem solved within the solutions of the ones before it,
all in the coordinates' natural units, :attr:`Mechanism.coordinate_units`):

1. the loop closure and the drivers: exact;
2. the values the user gave: exact where the loops allow it, else as close as possible; a given
   value that ends up off by more than ``tol`` (relative to its magnitude and unit) is an error
   naming it;
3. modal coordinates (and their rates) kept at their values: flexible links start as given
   (undeformed, at rest) unless the loops need them to move;
4. everything else changed least.

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.kinematics.rotations import translation as T
>>> m = build_mechanism([
...     rigid_link("ground", {"D": T([2, 0, 0])}), rigid_link("crank", {"B": T([1, 0, 0])}),
...     rigid_link("coupler", {"C": T([2, 0, 0])}), rigid_link("rocker", {"C": T([2, 0, 0])})], [
...     Joint("A", "revolute", "ground", "body", "crank", "body", (1.57,)),
...     Joint("B", "revolute", "crank", "B", "coupler", "body", (-1.0,)),
...     Joint("C", "revolute", "coupler", "C", "rocker", "C", (-1.5,)),
...     Joint("D", "revolute", "rocker", "body", "ground", "D", (-1.0,))])
>>> q = initial_positions(m, m.q_initial, given={"A.theta": 1.2})
>>> qd = initial_velocities(m, q, given={"A.theta": 3.0})
>>> round(float(q[0]), 12), round(float(qd[0]), 12)
(1.2, 3.0)
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

import numpy as np

from pipeline.core.errors import ConfigError, KinematicsError
from pipeline.kinematics.analysis import assemble
from pipeline.kinematics.closure import closure
from pipeline.kinematics.mechanism import Mechanism
from pipeline.kinematics.partition import RANK_RTOL

logger = logging.getLogger(__name__)

__all__ = ["initial_positions", "initial_velocities", "lexicographic_lsq", "reach"]


def _null(A: np.ndarray) -> np.ndarray:
    if A.shape[0] == 0:
        return np.eye(A.shape[1])
    _, s, Vt = np.linalg.svd(A)
    r = int(np.sum(s > RANK_RTOL * s[0])) if s.size and s[0] > 0 else 0
    return Vt[r:].T


def lexicographic_lsq(A: np.ndarray, b: np.ndarray, tiers) -> tuple[np.ndarray, float]:
    """z (k,) with A z = b in the least-squares sense, then each tier (E (r, k), d (r,))
    minimising |E z - d| among the minimisers of the ones before; and |A z - b|.

    Examples
    --------
    >>> z, res = lexicographic_lsq(np.array([[1.0, 1.0]]), np.array([2.0]),
    ...                            [(np.array([[1.0, 0.0]]), np.array([0.5]))])
    >>> z.round(12).tolist(), res < 1e-15
    ([0.5, 1.5], True)
    """
    k = A.shape[1]
    z = np.linalg.lstsq(A, b, rcond=RANK_RTOL)[0] if A.size else np.zeros(k)
    res = float(np.abs(A @ z - b).max(initial=0.0))
    N = _null(A)
    for E, d in tiers:
        if N.shape[1] == 0:
            break
        EN = E @ N
        y = np.linalg.lstsq(EN, d - E @ z, rcond=RANK_RTOL)[0]
        z = z + N @ y
        N = N @ _null(EN)
    return z, res


def _indices(mech: Mechanism, names) -> np.ndarray:
    return mech.indices(list(names)) if len(names) else np.zeros(0, dtype=int)


def _tiers(mech, free, given_idx, given_val, x, unit):
    """Tiers 2-4 of the module docstring over the ``free`` columns (scaled by ``unit``)."""
    pos = {c: k for k, c in enumerate(free)}
    rows = []
    g = [i for i in given_idx if i in pos]
    if g:
        E = np.zeros((len(g), free.size))
        for r, i in enumerate(g):
            E[r, pos[i]] = 1.0
        d = np.array([(given_val[list(given_idx).index(i)] - x[i]) / unit[i] for i in g])
        rows.append((E, d))
    modal = [i for i in mech.modal_coordinates if i in pos and i not in g]
    rest = [i for i in free if i not in g and i not in modal]
    for group in (modal, rest):
        if group:
            E = np.zeros((len(group), free.size))
            E[np.arange(len(group)), [pos[i] for i in group]] = 1.0
            rows.append((E, np.zeros(len(group))))
    return rows


def _check_given(mech, x, given_idx, given_val, unit, tol, what):
    off = [(mech.coordinates[i], v, x[i]) for i, v in zip(given_idx, given_val)
           if abs(x[i] - v) > tol * (unit[i] + abs(v))]
    if off:
        shown = ", ".join(f"{n} = {v:.6g} (the loops allow {w:.6g})" for n, v, w in off)
        raise ConfigError(f"initial {what} cannot be honoured: {shown}; the given values "
                          "over-determine the loops: give fewer of them")
    moved = [(mech.coordinates[i], v, x[i]) for i, v in zip(given_idx, given_val)
             if x[i] != v]
    if moved:
        logger.info("initial %s projected onto the loops: %s", what,
                    ", ".join(f"{n} {v:.9g} -> {w:.9g}" for n, v, w in moved))


def initial_positions(mech: Mechanism, q_guess: np.ndarray, fixed: Mapping[str, float] = {},
                      given: Mapping[str, float] = {}, *, tol: float = 1e-6,
                      closure_tol: float = 1e-12) -> np.ndarray:
    """Assembled q (n,) from the approximate ``q_guess`` (the joints' initial values).

    Parameters
    ----------
    fixed : coordinate -> value held exactly (drivers at t0), rad or m.
    given : coordinate -> value the user asked for (honoured exactly when the loops allow;
        else by least squares within ``tol``).

    Raises
    ------
    ConfigError
        A given value cannot be honoured (named, with the value the loops allow).
    ClosureError, KinematicsError
        The loops cannot be closed at all with the fixed values.
    """
    q = np.array(q_guess, dtype=float)
    for d in (fixed, given):
        for k, v in d.items():
            q[mech.index(k)] = float(v)
    try:
        return assemble(mech, q, tuple(fixed) + tuple(given), tol=closure_tol).q
    except KinematicsError as exc:
        if not given or "over-constrain" not in str(exc):
            raise
    # the given values over-determine the loops: least squares among them
    q = _nearest(mech, q, fixed, given, closure_tol)
    _check_given(mech, q, _indices(mech, given), np.array(list(given.values()), dtype=float),
                 mech.coordinate_units, tol, "coordinates")
    return q


def _nearest(mech: Mechanism, q: np.ndarray, fixed: Mapping[str, float],
             given: Mapping[str, float], closure_tol: float, iterations: int = 50
             ) -> np.ndarray:
    """The assembled q (n,) with ``fixed`` held whose ``given`` coordinates are nearest
    their values (Gauss-Newton on the closure with the given values as a lower tier,
    steps of at most 0.2 natural units)."""
    q = assemble(mech, q, tuple(fixed), tol=closure_tol).q
    unit = mech.coordinate_units
    free = np.setdiff1d(np.arange(mech.n), _indices(mech, fixed))
    gi, gv = _indices(mech, given), np.array(list(given.values()), dtype=float)
    w = np.asarray(mech.row_weights)
    for _ in range(iterations):
        c = closure(mech, q)
        A = (w[:, None] * c.J)[:, free] * unit[free]
        z, _ = lexicographic_lsq(A, -w * c.r, _tiers(mech, free, gi, gv, q, unit))
        step = np.clip(z, -0.2, 0.2)
        q[free] += step * unit[free]
        if np.abs(step).max(initial=0.0) < 1e-14 and np.abs(w * c.r).max() <= closure_tol:
            break
    return assemble(mech, q, tuple(fixed), tol=closure_tol).q  # polish the closure


def reach(mech: Mechanism, q_guess: np.ndarray, fixed: Mapping[str, float], name: str,
          closure_tol: float = 1e-12, rtol: float = 1e-9) -> tuple[float, float] | None:
    """(lowest, highest) value of coordinate ``name`` at which the loops close with the
    other ``fixed`` coordinates held, on the branch the assembly from ``q_guess`` finds
    with ``name`` at its value in ``q_guess`` (or free, if they cannot close there); None if
    the loops cannot close even with it free, or no step from there closes.

    From that assembly the value is moved each way in steps of 0.05 of its unit (steps
    short enough not to leap a gap: a cylinder's rod cannot pass through its foot pin, but
    a long step lands on the mirror branch beyond) until the loops no longer close, then
    the edge is bisected to ``rtol`` of its unit, each trial assembled from the last one
    that closed. An edge further than 10 length scales (a translation) or 2 pi (an angle)
    away is +-inf (no limit that way).
    """
    others = {k: v for k, v in fixed.items() if k != name}
    i = mech.index(name)
    q0 = None
    # from the guess's own value of the coordinate first (the joint's initial value), then
    # with it free: a free assembly may land on the edge itself, a toggle, and stall there
    for held in (tuple(others) + (name,), tuple(others)):
        try:
            q0 = assemble(mech, np.asarray(q_guess, dtype=float), held, tol=closure_tol).q
            break
        except KinematicsError:
            continue
    if q0 is None:
        return None
    unit = float(mech.coordinate_units[i])
    limit = 10.0 * unit if mech.translations[i] else 2.0 * np.pi
    held = tuple(others) + (name,)

    def closes(q, v):
        trial = q.copy()
        trial[i] = v
        try:
            return assemble(mech, trial, held, tol=closure_tol).q
        except KinematicsError:
            return None

    ends = []
    for sign in (-1.0, 1.0):
        q_in, v_in, step, v_out = q0, float(q0[i]), 0.05 * unit, None
        while abs(v_in - q0[i]) < limit:
            q = closes(q_in, v_in + sign * step)
            if q is None:
                v_out = v_in + sign * step
                break
            q_in, v_in = q, v_in + sign * step
        if v_out is None:
            ends.append(sign * np.inf)
            continue
        while abs(v_out - v_in) > rtol * unit:
            mid = 0.5 * (v_in + v_out)
            q = closes(q_in, mid)
            if q is None:
                v_out = mid
            else:
                q_in, v_in = q, mid
        ends.append(v_in)
    if ends[0] == ends[1]:
        return None  # no step closed either way: a singular start tells no range
    return ends[0], ends[1]


def initial_velocities(mech: Mechanism, q: np.ndarray, fixed: Mapping[str, float] = {},
                       given: Mapping[str, float] = {}, *, tol: float = 1e-6,
                       qd_guess: np.ndarray | None = None) -> np.ndarray:
    """Rates qd (n,) at the assembled q satisfying the loops (J qd = 0).

    Parameters
    ----------
    fixed : coordinate -> rate held exactly (drivers at t0), rad/s or m/s.
    given : coordinate -> rate the user asked for.
    qd_guess : (n,) rates whose modal entries are kept where possible (default zero).

    Raises
    ------
    ConfigError
        The fixed rates contradict the loops, or a given rate cannot be honoured (named).
    """
    x = np.zeros(mech.n) if qd_guess is None else np.array(qd_guess, dtype=float)
    fi = _indices(mech, fixed)
    x[fi] = np.array(list(fixed.values()), dtype=float)
    gi, gv = _indices(mech, given), np.array(list(given.values()), dtype=float)
    free = np.setdiff1d(np.arange(mech.n), fi)
    if not mech.topology.loops:
        x[gi] = gv
        return x
    unit = mech.coordinate_units
    w = np.asarray(mech.row_weights)
    J = w[:, None] * closure(mech, q).J
    A = J[:, free] * unit[free]
    b = -J @ x  # x holds the fixed rates (and the guess's free entries, moved below)
    tiers = _tiers(mech, free, gi, gv, x, unit)
    z, res = lexicographic_lsq(A, b, tiers)
    # rows are dimensionless per unit rate: compare with the rates given, in natural units
    scale = max(float(np.abs(x[fi] / unit[fi]).max(initial=0.0)),
                float(np.abs(gv / unit[gi]).max(initial=0.0)))
    if res > 1e-9 * scale + 1e-14:
        names = [mech.coordinates[i] for i in fi]
        raise ConfigError(f"initial velocities: the driven rates {names} contradict the loops "
                          f"(closure rate error {res:.3g}); check the drivers at t = 0")
    x[free] += z * unit[free]
    _check_given(mech, x, gi, gv, unit, tol, "velocities")
    exact = np.abs(x[gi] - gv) <= 1e-12 * (np.abs(gv) + unit[gi])
    x[gi[exact]] = gv[exact]  # honoured: the rounding of the solve is not the user's value
    return x
