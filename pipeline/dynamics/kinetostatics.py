"""Kinetostatics: the actuator forces a prescribed motion needs.

The driven coordinates s (``system.drivers``) and any ``hold`` coordinates
(default: every free joint coordinate left over, e.g. a chassis slide) are
prescribed; the loops close for the dependent ones. With B_c = dq/ds (n, c)
(:func:`pipeline.dynamics.statics.velocity_transform` on the prescribed
columns), the principle of virtual work in the prescribed coordinates gives
the generalized forces the drivers must apply (the Lagrange multipliers of the
driver constraints):

    quasi-static   lambda = -B_c^T Q_static(q, t)
    with inertia   lambda =  B_c^T (M q'' - rhs(q, q', t)),  rhs = Q - h,

with q', q'' from velocity and acceleration analysis (driver rates and
accelerations, held coordinates at rest). For a cylinder (driven prismatic
coordinate) lambda is its axial force in N, positive pushing (extending);
for a driven revolute it is the torque in N m. Flexible links: the modal
coordinates are solved for static equilibrium at each time (quasi-static
deflection; their rates are neglected in the inertial terms).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.kinematics.drivers import Ramp
>>> from pipeline.dynamics import BodyMass, System
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(2.0, [1.0, 0, 0], np.eye(3))}, [0, -10.0, 0],
...            drivers={"pin.theta": Ramp(0.0, 1.0)})
>>> r = kinetostatics(s, np.array([0.0]), np.zeros(1))
>>> float(r.forces[0, 0])  # holding torque m g d
20.0
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.compiled import link_terms, second_order_acceleration
from pipeline.dynamics.equations import equations
from pipeline.dynamics.statics import (
    reduced_coordinates,
    static_equilibrium,
    static_forces,
    velocity_transform,
)
from pipeline.kinematics import (
    closure,
    evaluate_tree,
    solve_acceleration,
    solve_position,
    solve_velocity,
)
from pipeline.kinematics.failures import ClosureError, SingularConfigurationError
from pipeline.kinematics.partition import select_partition
from pipeline.kinematics.poses import step_pose

__all__ = ["JointReactions", "KinetostaticResult", "joint_reactions", "kinetostatics"]


@dataclass(frozen=True)
class KinetostaticResult:
    """Actuator forces along a driver motion (partial on failure).

    Attributes
    ----------
    t : (T,) s.  q, qd, qdd : (T, n) coordinates, rates, accelerations.
    names : (c,) prescribed coordinates (drivers, then held ones).
    forces : (T, c) generalized force each must apply, N or N m.
    inertia : whether M q'' + h was included.
    success, message.
    reactions : per time a :class:`JointReactions` (empty unless asked for).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    names: tuple[str, ...]
    forces: np.ndarray
    inertia: bool
    success: bool
    message: str
    reactions: tuple = ()

    def force(self, name: str) -> np.ndarray:
        """(T,) force history of prescribed coordinate ``name``."""
        if name not in self.names:
            raise ConfigError(f"kinetostatics: '{name}' is not prescribed; prescribed: "
                              f"{list(self.names)}")
        return self.forces[:, self.names.index(name)]


def _held(system, q, hold):
    """Names of drivers + held coordinates (default: the free joint coordinates)."""
    if hold is None:
        _, red = reduced_coordinates(system, q)
        modal = set(system.mechanism.modal_coordinates.tolist())
        hold = [system.mechanism.coordinates[i] for i in red.x if i not in modal]
    return list(system.drivers) + [h for h in hold if h not in system.drivers]


def _state(system, q, red, t, names, idx):
    """Closed q, qd, qdd at t (drivers from their histories, held coordinates at rest)."""
    mech = system.mechanism
    qd, qdd = np.zeros(mech.n), np.zeros(mech.n)
    for name, drv in system.drivers.items():
        i = mech.index(name)
        q[i], qd[i], qdd[i] = drv.value(t), drv.rate(t), drv.accel(t)
    part = red.partition
    if part.dependent.size:
        q = solve_position(mech, q, part)[0]
        if red.x.size:  # modal coordinates: quasi-static deflection
            q = static_equilibrium(system, q, t=t, hold=names).q
        c = closure(mech, q, qd)
        qd = solve_velocity(c.J, part, qd)
        qdd = solve_acceleration(c.J, closure(mech, q, qd).gamma, part, qdd)
    elif red.x.size:
        q = static_equilibrium(system, q, t=t, hold=names).q
    return q, qd, qdd


def _repartition(system, q, red, idx):
    c = closure(system.mechanism, q)
    part = select_partition(system.mechanism, c.J, idx, q=q,
                            secondary=system.mechanism.modal_coordinates)
    return type(red)(red.x, red.held, part)


def _closed_state(system, q, red, tk, names, idx):
    """(q, q', q'') at tk and the partition used (re-selected once if the old one fails)."""
    try:
        return _state(system, q.copy(), red, tk, names, idx), red
    except (ClosureError, SingularConfigurationError):
        red = _repartition(system, q, red, idx)
        return _state(system, q.copy(), red, tk, names, idx), red


def _actuation(system, q, qd, qdd, t, red, idx, names, inertia, reactions):
    """Forces (c,) of the prescribed coordinates and, if asked, the joint reactions."""
    Bc = velocity_transform(system, q, red, idx)
    if inertia:
        M, rhs = equations(system, q, qd, t)
        F = Bc.T @ (M @ qdd - rhs)
    else:
        F = -Bc.T @ static_forces(system, q, t)
        qd = qdd = np.zeros(system.mechanism.n)
    r = joint_reactions(system, q, qd, qdd, t, dict(zip(names, F))) if reactions else None
    return F, r


def kinetostatics(system, t: np.ndarray, q_guess: np.ndarray, *, inertia: bool = False,
                  hold=None, reactions: bool = False) -> KinetostaticResult:
    """Actuator forces along the drivers' motion at times t (T,) s.

    Parameters
    ----------
    q_guess : (n,) approximate assembly at t[0].
    inertia : include M q'' + h (else quasi-static).
    hold : names of coordinates held fixed besides the drivers (default: every
        free joint coordinate); their holding forces are reported too.
    reactions : also compute the joint reactions (:func:`joint_reactions`) at every time.

    Raises
    ------
    ConfigError
        No drivers, bad times or q_guess.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if not system.drivers:
        raise ConfigError("kinetostatics: system.drivers: expected at least one driven "
                          "coordinate, got none")
    if t.ndim != 1 or not np.all(np.isfinite(t)):
        raise ConfigError(f"kinetostatics: t: expected finite times (T,), got {t.shape}")
    mech = system.mechanism
    q = np.array(q_guess, dtype=float)
    if q.shape != (mech.n,) or not np.all(np.isfinite(q)):
        raise ConfigError(f"kinetostatics: q_guess: expected {mech.n} finite values, got "
                          f"shape {q.shape}")
    for f in system.forces:
        f.validate(system)
    for name, drv in system.drivers.items():
        q[mech.index(name)] = drv.value(t[0])
    names = _held(system, q, hold)
    idx = mech.indices(names).astype(int)
    q, red = reduced_coordinates(system, q, names)
    Q = np.full((t.size, 3, mech.n), np.nan)
    F = np.full((t.size, idx.size), np.nan)
    ok, msg, reac = True, "completed", []
    for k, tk in enumerate(t):
        try:
            (qk, qd, qdd), red = _closed_state(system, q, red, tk, names, idx)
            F[k], r = _actuation(system, qk, qd, qdd, tk, red, idx, names, inertia, reactions)
        except (ClosureError, SingularConfigurationError, np.linalg.LinAlgError) as exc:
            ok, msg = False, f"stopped at t = {tk:.6g} s: {exc}"
            break
        reac += [r] if r is not None else []
        q = qk
        Q[k] = qk, qd, qdd
    n_ok = k + 1 if ok else k
    return KinetostaticResult(t[:n_ok], Q[:n_ok, 0], Q[:n_ok, 1], Q[:n_ok, 2], tuple(names),
                              F[:n_ok], inertia, ok, msg, tuple(reac[:n_ok]))


# ----------------------------------------------------------------------------- reactions
@dataclass(frozen=True)
class JointReactions:
    """Joint reactions at one state: the wrench the parent link exerts on the child link
    at the joint point (the child frame's origin), ground axes.

    Attributes
    ----------
    joints : joint names.  force : (J, 3) N.  moment : (J, 3) N m about the joint point.
    residual : max |Newton-Euler + joint-axis residual| of the solve (N, N m); near
        zero when the actuator forces balance the loads and inertia of every body.
    """

    joints: tuple[str, ...]
    force: np.ndarray
    moment: np.ndarray
    residual: float


def _vee(W: np.ndarray) -> np.ndarray:
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def _body_wrench(system, tree, q, qd, qdd, li, body) -> np.ndarray:
    """(6,) gravity minus inertia wrench of one body about the ground origin.

    With X = int rho R'' R_bar^T = A'' J A^T + 2 A' Nd A^T + A Ndd A^T
    (Nd = sum eta'_a N_a^T): momentum rate X[:3, 3], angular momentum rate
    vee(X - X^T)[:3, :3] (DESIGN §2 invariants).
    """
    idx = system.mechanism.modal_index[li]
    J, N = link_terms(body, q[idx])
    A, Ad = tree.A[li], tree.Ad[li]
    Add = np.tensordot(qdd, tree.dA[li], axes=1) + tree.Add[li]
    Nd = np.tensordot(qd[idx], N.transpose(0, 2, 1), axes=1) if idx.size else 0.0 * J
    Ndd = np.tensordot(qdd[idx], N.transpose(0, 2, 1), axes=1) if idx.size else 0.0 * J
    X = Add @ J @ A.T + 2.0 * Ad @ Nd @ A.T + A @ Ndd @ A.T
    if body.second_order_moments.size:  # the moving mass of a bending link: A u2''|0 xb^T A^T
        X += A[:, :3] @ second_order_acceleration(body, qd[idx]).T @ A.T
    s = (A @ J[:, 3])[:3]
    g = system.gravity
    return np.concatenate([J[3, 3] * g - X[:3, 3], np.cross(s, g) - _vee(X[:3, :3] - X[:3, :3].T)])


def _joint_axes(system, tree, q, j):
    """Joint point p (3,) and unit twists (k, 6) [v, w] of the joint's variables."""
    mech = system.mechanism
    joint, jidx = mech.joints[j], mech.joint_index[j]
    step = mech.marker(joint.parent, joint.parent_frame)
    Pp = step_pose(step, tree.A, q)
    Pc = Pp @ joint.kind.motion.transform(q[jidx])
    dP = Pp @ joint.kind.motion.derivatives(q[jidx]) if jidx.size else np.zeros((0, 4, 4))
    xi = np.array([np.concatenate([d[:3, 3], _vee(d[:3, :3] @ Pc[:3, :3].T)]) for d in dP])
    return Pc[:3, 3], xi.reshape(-1, 6)


def _external(system, tree, q, qd, t, W, Q, z=None):
    """Add the force elements' loads to the body wrenches W (L, 6); joint elements to Q
    (z: the elements' own states, System.state_slices, where the caller has them)."""
    mech = system.mechanism
    for f in system.forces:
        args = (system, tree, q, qd, t, *system.states_of(f, z))
        if hasattr(f, "coordinate"):
            Q += f.generalized_force(*args)
            continue
        for ld in f.loads(*args):
            li = mech.link_index(ld.link)
            W[li, :3] += ld.force
            W[li, 3:] += np.cross(ld.point, ld.force) + ld.torque


def joint_reactions(system, q, qd, qdd, t: float, actuators: dict[str, float],
                    z=None) -> JointReactions:
    """Reactions of every joint from Newton-Euler of every moving link.

    Unknowns: one wrench per joint; equations: the six balance equations of each
    moving link (loads, gravity, inertia) and, per joint variable, the transmitted
    generalized force (joint force elements + ``actuators[name]``). Least squares
    (minimum norm: components a planar loop leaves indeterminate come out as the
    smallest ones). ``z``: the force elements' own states at that time (a hydraulic
    cylinder's pressures; SimulationResult.states), for a system with such elements.
    """
    mech = system.mechanism
    tree = evaluate_tree(mech, q, qd, derivatives=True)
    L, nj = len(mech.links), len(mech.joints)
    W, Qj = np.zeros((L, 6)), np.zeros(mech.n)
    for name, body in system.bodies.items():
        li = mech.link_index(name)
        W[li] += _body_wrench(system, tree, q, qd, qdd, li, body)
    _external(system, tree, q, qd, t, W, Qj, z)
    for name, value in actuators.items():
        Qj[mech.index(name)] += value
    rows_b = np.zeros((6 * L, 6 * nj))
    axis_rows, axis_rhs = [], []
    for j, joint in enumerate(mech.joints):
        p, xi = _joint_axes(system, tree, q, j)
        S = np.eye(6)
        S[3:, :3] = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        for link, sign in ((joint.child, 1.0), (joint.parent, -1.0)):
            li = mech.link_index(link)
            rows_b[6 * li:6 * li + 6, 6 * j:6 * j + 6] += sign * S
        for k, i in enumerate(mech.joint_index[j]):
            row = np.zeros(6 * nj)
            row[6 * j:6 * j + 6] = xi[k]  # power f . v_p + n . w
            axis_rows.append(row)
            axis_rhs.append(Qj[i])
    keep = np.ones(6 * L, bool)
    keep[6 * mech.link_index(mech.ground):6 * mech.link_index(mech.ground) + 6] = False
    A = np.vstack([rows_b[keep]] + ([np.array(axis_rows)] if axis_rows else []))
    b = np.concatenate([-W.reshape(-1)[keep], np.array(axis_rhs)])
    w = np.linalg.lstsq(A, b, rcond=None)[0]
    res = float(np.abs(A @ w - b).max(initial=0.0))
    w = w.reshape(nj, 6)
    return JointReactions(tuple(j.name for j in mech.joints), w[:, :3], w[:, 3:], res)
