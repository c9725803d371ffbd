"""Closed loops by coordinate partitioning (DESIGN §4).

Independent coordinates: the modal coordinates and the free joint variables
(drivers are prescribed functions of time and not integrated); dependent
ones come from position analysis at every evaluation, so the loops never
drift. Modal coordinates become dependent only where the joints cannot satisfy the
loops (a planar loop whose flexible link keeps out-of-plane modes: the pins lock them). Velocities q' = B q'_I + b (b from the driver rates), accelerations
q'' = B q''_I + c, and the reduced equations

    (B^T M B) q''_I = B^T (rhs - M c).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.dynamics.system import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(1.0, [1.0, 0, 0], np.zeros((3, 3)))},
...            gravity=[0.0, -9.81, 0.0])
>>> red = partition_system(s, np.zeros(1))
>>> st = reduced_state(s, red, np.zeros(1), np.zeros(1), 0.0, np.zeros(1))
>>> round(float(st.qdd[0]), 12)
-9.81
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pipeline.dynamics.compiled import closed_state as _closed_state
from pipeline.dynamics.compiled import reduced_solve as _reduced_solve
from pipeline.dynamics.equations import EquationTerms, equation_terms
from pipeline.kinematics.analysis import solve_position, velocity_map
from pipeline.kinematics.closure import closure, closure_rates
from pipeline.kinematics.partition import Partition, normalised_jacobian, select_partition
from pipeline.kinematics.poses import TreeState

__all__ = ["DynamicPartition", "ReducedState", "complete_position", "driver_state",
           "partition_system", "reduced_state", "repartition", "velocity_transform"]


@dataclass(frozen=True)
class DynamicPartition:
    """Coordinate split for the dynamics.

    Attributes
    ----------
    kin : kinematics Partition (rows, dependent, prescribed = driven + modal, free).
    independent : (nI,) integrated coordinates (modal and free, sorted).
    driven : (p,) driven coordinate indices; ``drivers`` their driver objects.
    has_loops : False for a tree (no position analysis needed).
    """

    kin: Partition
    independent: np.ndarray
    driven: np.ndarray
    drivers: tuple
    has_loops: bool


@dataclass(frozen=True)
class ReducedState:
    """Full state reconstructed from the independent one, with the reduced dynamics.

    q, qd, qdd : (n,); qdd_I : (nI,); B : (n, nI); terms : EquationTerms at (q, qd).
    driver_forces : (p,) force (N) or torque (N m) each driver applies along its
        coordinate to impose the prescribed motion.
    residual : (6 k,) closure residual at q (m, rad).
    Bp : (n, p) dq/dq_p through the loops (see :func:`velocity_transform`).
    J : (6 k, n) closure Jacobian at q, or None for a tree.
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    qdd_I: np.ndarray
    B: np.ndarray
    terms: EquationTerms
    driver_forces: np.ndarray
    residual: np.ndarray
    Bp: np.ndarray
    J: np.ndarray | None


def partition_system(system, q: np.ndarray) -> DynamicPartition:
    """Choose the independent coordinates at an assembled configuration q (n,)."""
    mech = system.mechanism
    names = list(system.drivers)
    driven = mech.indices(names) if names else np.zeros(0, dtype=int)
    J = closure(mech, np.asarray(q, dtype=float)).J
    kin = select_partition(mech, J, driven, q=np.asarray(q, dtype=float),
                           secondary=mech.modal_coordinates)
    return DynamicPartition(kin, np.sort(kin.free).astype(int), driven,
                            tuple(system.drivers[k] for k in names), bool(mech.topology.loops))


def _rcond(mech, J: np.ndarray, kin: Partition) -> float:
    """Smallest / largest singular value of the normalised dependent block."""
    if kin.dependent.size == 0:
        return 1.0
    # column normalisation is per column: normalising only the dependent ones is the same
    s = np.linalg.svd(normalised_jacobian(mech, J[:, kin.dependent], kin.dependent)[0][kin.rows],
                      compute_uv=False)
    return float(s[-1] / s[0]) if s[0] > 0 else 0.0


def repartition(system, part: DynamicPartition, q: np.ndarray, factor: float = 10.0,
                J: np.ndarray | None = None) -> DynamicPartition | None:
    """A better-conditioned split at q (n,), or None to keep ``part``.

    Looks for one only when the current dependent block is poorly conditioned (rcond
    <= 0.1) and has lost half its conditioning since it was chosen (or last examined),
    e.g. when it approaches a toggle; re-selects (DESIGN §3) when the best block
    available is ``factor`` times better conditioned. When it looked and kept the
    coordinates it returns ``part`` with the present conditioning as the new
    reference (same ``independent``), so a steady, moderately conditioned
    mechanism is not re-examined at every step. ``J``: the closure Jacobian at q
    if the caller has it. Raises SingularConfigurationError if no choice is regular
    (the loops themselves are singular at q).
    """
    if not part.has_loops or not part.kin.dependent.size:
        return None
    mech = system.mechanism
    if J is None:
        J = closure(mech, q).J
    now = _rcond(mech, J, part.kin)
    if now > 0.1 or now >= 0.5 * part.kin.rcond:  # well or still as conditioned as chosen
        return None
    kin = select_partition(mech, J, part.kin.prescribed, q=q, secondary=part.kin.secondary)
    if kin.rcond < factor * now or np.array_equal(kin.dependent, part.kin.dependent):
        return replace(part, kin=replace(part.kin, rcond=now))
    return DynamicPartition(kin, np.sort(kin.free).astype(int), part.driven, part.drivers, True)


def driver_state(part: DynamicPartition, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(values, rates, accelerations), each (p,), of the drivers at t (s)."""
    p = len(part.drivers)
    out = np.empty((3, p))
    for k, d in enumerate(part.drivers):
        if hasattr(d, "state"):  # Driver: all three in one pass
            out[:, k] = d.state(t)
        else:  # any object with value/rate/accel
            out[0, k], out[1, k], out[2, k] = d.value(t), d.rate(t), d.accel(t)
    return out[0], out[1], out[2]


def _close(system, part: DynamicPartition, q_I: np.ndarray, t: float, q_guess: np.ndarray,
           tol: float, values: np.ndarray | None = None):
    """(q (n,), ClosureValue with Jacobian at q, or None for a tree); ``values``: the
    drivers' values at t if the caller has them."""
    q = np.array(q_guess, dtype=float)
    q[part.independent] = q_I
    q[part.driven] = driver_state(part, t)[0] if values is None else values
    if not part.has_loops:
        return q, None
    q, c, _ = solve_position(system.mechanism, q, part.kin, tol=tol)
    return q, c


def complete_position(system, part: DynamicPartition, q_I: np.ndarray, t: float,
                      q_guess: np.ndarray, tol: float = 1e-12):
    """q (n,) with q_I, the driver values at t and the dependent coordinates closed,
    and the closure Jacobian there ((6 k, n), None for a tree).

    Raises ClosureError / SingularConfigurationError from position analysis.
    """
    q, c = _close(system, part, q_I, t, q_guess, tol)
    return q, None if c is None else c.J


def velocity_transform(system, part: DynamicPartition, J: np.ndarray | None,
                       t: float, rates: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """B (n, nI), B_p (n, p) and b (n,) with q' = B q'_I + b, b = B_p (driver rates).

    B_p [i, k] = dq_i / dq_p_k: how the k-th driven coordinate moves the others
    through the loops (its transpose maps the equations onto the driver force).
    """
    I, P = part.independent, part.driven
    both = velocity_map(J, part.kin, np.concatenate([I, P]), system.mechanism.n)
    B, Bp = both[:, :I.size], both[:, I.size:]
    if rates is None:
        rates = np.array([d.rate(t) for d in part.drivers], dtype=float)
    return B, Bp, Bp @ rates


def reduced_state(system, part: DynamicPartition, q_I: np.ndarray, qd_I: np.ndarray, t: float,
                  q_guess: np.ndarray, drive=None) -> ReducedState:
    """Close the loops, build q', and solve the reduced equations for q''_I.

    One evaluation of the link poses serves the position Newton's last iterate, the
    velocity transform, gamma and the equations (the rates are added to it once q' is
    known). ``drive``: :func:`driver_state` at t if the caller has it (an implicit
    integrator evaluates many states at one time).
    """
    mech = system.mechanism
    values, rates, accels = driver_state(part, t) if drive is None else drive
    if part.has_loops and part.kin.dependent.size:
        st = _compiled_state(system, part, q_I, qd_I, t, q_guess, values, rates, accels)
        if st is None:  # the plain Newton from the guess did not converge fast: the damped,
            # least-squares-backed position analysis closes the loops, the same pass from there
            q, _ = _close(system, part, q_I, t, q_guess, 1e-12, values)
            st = _compiled_state(system, part, q_I, qd_I, t, q, values, rates, accels,
                                 strict=True)
        return st
    # a tree, or loops whose rows the driven and modal coordinates fill: q' = B q'_I + b
    # with B a selection, no closure to solve
    q, cv = _close(system, part, q_I, t, q_guess, 1e-12, values)
    B, Bp, b = velocity_transform(system, part, None if cv is None else cv.J, t, rates)
    qd = B @ qd_I + b
    c = np.zeros(mech.n)
    c[part.driven] = accels
    tree, residual = None, np.zeros(0)
    if cv is not None:
        cg = closure_rates(mech, cv, q, qd)
        tree, residual = cg.tree, cv.r
    terms = equation_terms(system, q, qd, t, tree=tree)
    return _solve_reduced(q, qd, B, Bp, c, terms, residual, None if cv is None else cv.J)


def _solve_reduced(q, qd, B, Bp, c, terms, residual, J) -> ReducedState:
    """(B^T M B) q''_I = B^T (rhs - M c), q'' = B q''_I + c and the driver forces, compiled
    (:func:`pipeline.dynamics.compiled.reduced_solve`); non-finite terms (a trial state far
    off, which numba's solve refuses) give non-finite accelerations, for the integrator to
    reject the step."""
    M, rhs = terms.M, terms.rhs
    if not B.shape[1]:
        qdd_I, qdd, lam = np.zeros(0), c.copy(), Bp.T @ (M @ c - rhs)
    else:
        try:
            qdd_I, qdd, lam = _reduced_solve(np.ascontiguousarray(B), np.ascontiguousarray(Bp),
                                             M, rhs, c)
        except ValueError:  # numba's LinAlgError too: singular, or non-finite entries
            if all(np.isfinite(x).all() for x in (B, M, rhs, c)):
                raise  # a singular mass matrix: the caller names it
            qdd_I = np.full(B.shape[1], np.nan)
            qdd, lam = np.full(q.shape[0], np.nan), np.full(Bp.shape[1], np.nan)
    return ReducedState(q, qd, qdd, qdd_I, B, terms, lam, residual, Bp, J)


def _compiled_state(system, part: DynamicPartition, q_I, qd_I, t, q_guess, values, rates,
                    accels, strict: bool = False) -> ReducedState | None:
    """:func:`reduced_state` by the fused compiled pass (plain Newton from q_guess); None
    when that Newton does not converge or its block is singular, so that the caller runs
    the damped, least-squares-backed position analysis instead. ``strict`` (q_guess closed
    by that analysis): a singular block raises LinAlgError, as a singular position does."""
    mech = system.mechanism
    I, P, kin = part.independent, part.driven, part.kin
    q0 = np.array(q_guess, dtype=float)
    q0[I] = q_I
    q0[P] = values
    nI = I.size
    try:
        out = _closed_state(mech.compiled, system.compiled_masses, q0, kin.rows, kin.dependent,
                            np.concatenate([I, P]), np.concatenate([qd_I, rates]),
                            np.concatenate([np.zeros(nI), accels]), mech.row_weights,
                            1e-12, system.gravity4)
    except (np.linalg.LinAlgError, ValueError):  # singular block, non-finite entries
        if strict:
            raise
        return None
    if out is None:
        if strict:  # a closed start that a Newton step from it leaves open: singular here
            raise np.linalg.LinAlgError("the loops' dependent block is singular at the "
                                        "closed configuration")
        return None
    q, r, J, X, qd, c, A, dA, Ad, Add, M, h, Qg = out
    B, Bp = X[:, :nI], X[:, nI:]
    terms = equation_terms(system, q, qd, t, tree=TreeState(A, dA, Ad, Add), inertia=(M, h, Qg))
    return _solve_reduced(q, qd, B, Bp, c, terms, r, J)
