"""Static equilibrium in the independent coordinates of a closed-loop machine.

Unknowns x: the free joint coordinates (neither driven nor dependent) and
every modal coordinate, so static elastic deflection comes out with the
joint configuration. Driven coordinates are held at ``driver.value(t)``;
dependent ones follow from position analysis (closure) for every x. With the
velocity transform B = dq/dx (n, k) (B[x] = I, B[dep] = -J_d^-1 J_x) the
reduced equilibrium is

    f(x) = B^T (Q_gravity + Q_elastic + Q_forces)(q(x)) = 0,

solved by Newton with a central-difference tangent df/dx (each evaluation
closes the loops). ``-df/dx`` at the solution is the tangent stiffness of the
reduced system (used by :mod:`pipeline.dynamics.linearize`).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.dynamics import BodyMass, System
>>> from pipeline.dynamics.forces import JointSpringDamper
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> s = System(mech, {"arm": BodyMass.rigid(1.0, [1.0, 0, 0], np.eye(3))}, [0, -9.81, 0],
...            forces=[JointSpringDamper("k", "pin.theta", stiffness=100.0)])
>>> r = static_equilibrium(s, np.zeros(1))
>>> r.success, bool(abs(100.0 * r.q[0] + 9.81 * np.cos(r.q[0])) < 1e-9)
(True, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.equations import elastic_forces
from pipeline.dynamics.gravity import gravity_force
from pipeline.kinematics import assemble, closure, evaluate_tree, solve_position
from pipeline.kinematics.analysis import velocity_map
from pipeline.kinematics.failures import ClosureError, SingularConfigurationError
from pipeline.kinematics.partition import Partition

__all__ = ["ReducedCoordinates", "StaticResult", "reduced_coordinates", "reduced_static_force",
           "static_equilibrium", "static_forces", "trapped_states", "velocity_transform"]


@dataclass(frozen=True)
class ReducedCoordinates:
    """Coordinate split of a static or linearised analysis.

    Attributes
    ----------
    x : (k,) indices in q of the unknowns (free joint coordinates, then modal).
    held : (h,) indices held at given values (driven coordinates).
    partition : kinematic partition (dependent coordinates, closure rows).
    """

    x: np.ndarray
    held: np.ndarray
    partition: Partition


@dataclass(frozen=True)
class StaticResult:
    """Outcome of :func:`static_equilibrium` (failure is a status, not an exception).

    Attributes
    ----------
    q : (n,) last configuration (closed loops).
    coordinates : names of the unknowns x.
    residual : (k,) reduced force f(x) at q, N or N m.
    stiffness : (k, k) tangent stiffness -df/dx at q.
    Q : (n,) total static generalized force at q (gravity + elastic + elements).
    iterations, success, message.
    reduced : the coordinate split used (None if the start could not be assembled).
    z : (nz,) the force elements' states at q (as given, or with ``trapped`` those the
        trapped oil has there), None without them.
    """

    q: np.ndarray
    coordinates: tuple[str, ...]
    residual: np.ndarray
    stiffness: np.ndarray
    Q: np.ndarray
    iterations: int
    success: bool
    message: str
    reduced: ReducedCoordinates | None = None
    z: np.ndarray | None = None


def static_forces(system, q: np.ndarray, t: float = 0.0, qd: np.ndarray | None = None,
                  z=None):
    """(n,) Q_gravity + Q_elastic + sum of the force elements at (q, qd = 0 by default, t)
    and the elements' states z (nz,) (None: an element with states refuses; a callable:
    the states at q, z(q), e.g. :func:`trapped_states`)."""
    q = np.asarray(q, dtype=float)
    qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=float)
    tree = evaluate_tree(system.mechanism, q)
    z = z(q) if callable(z) else z
    return gravity_force(system, tree, q) + elastic_forces(system, q, qd)[0] \
        + system.compiled_forces.forces(tree, q, qd, t, z)[0]


def reduced_coordinates(system, q: np.ndarray, hold=()) -> tuple[np.ndarray, ReducedCoordinates]:
    """Assemble at q with the drivers and ``hold`` coordinates prescribed; split the rest.

    Returns the closed q (n,) and the split. Raises ClosureError if the loops cannot close.
    """
    mech = system.mechanism
    held = list(system.drivers) + [h for h in hold if h not in system.drivers]
    a = assemble(mech, q, driven=held)
    part = a.partition
    x = np.sort(part.free).astype(int)  # free joints and the independent modal coordinates
    return a.q, ReducedCoordinates(x, mech.indices(held).astype(int), part)


def velocity_transform(system, q: np.ndarray, red: ReducedCoordinates,
                       columns: np.ndarray | None = None) -> np.ndarray:
    """(n, k) B = dq/dx_c at closed q for the coordinates ``columns`` (default red.x).

    Columns may include held coordinates (B for the actuator reactions).
    """
    cols = red.x if columns is None else columns
    part = red.partition
    J = closure(system.mechanism, q).J if part.dependent.size else None
    return velocity_map(J, part, cols, system.mechanism.n)


def place(system, q_ref, red, xv, t):
    """Closed q (n,) with x = xv and the drivers at t (other entries from q_ref)."""
    q = np.array(q_ref, dtype=float)
    q[red.x] = xv
    for name, drv in system.drivers.items():
        q[system.mechanism.index(name)] = float(drv.value(t))
    if red.partition.dependent.size:
        q = solve_position(system.mechanism, q, red.partition)[0]
    return q


def reduced_static_force(system, q_ref: np.ndarray, red: ReducedCoordinates, xv: np.ndarray,
                         t: float = 0.0, z: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
    """f(x) = B^T Q (k,) and the closed q (n,) at x = xv (other entries from q_ref), the
    elements' states held at z."""
    q = place(system, q_ref, red, xv, t)
    return velocity_transform(system, q, red).T @ static_forces(system, q, t, z=z), q


def fd_steps(system, red: ReducedCoordinates, xv: np.ndarray, rel: float = 1e-6) -> np.ndarray:
    """Central-difference steps: rel max(1, |x|, length scale) for joints, rel (1 + |eta|) modal."""
    mech = system.mechanism
    modal = set(mech.modal_coordinates.tolist())
    out = np.empty(xv.size)
    for k, i in enumerate(red.x):
        name = mech.coordinates[i]
        if i in modal:
            out[k] = rel * (1.0 + abs(xv[k]))
        else:
            out[k] = rel * max(1.0, abs(xv[k]), mech.length_scale if name.endswith(
                (".d", ".x", ".y", ".z")) else 1.0)
    return out


def tangent(system, q_ref, red, xv, t=0.0, z=None) -> np.ndarray:
    """(k, k) df/dx by central differences of :func:`reduced_static_force` (states held
    at z)."""
    h = fd_steps(system, red, xv)
    D = np.empty((xv.size, xv.size))
    for k in range(xv.size):
        e = np.zeros(xv.size)
        e[k] = h[k]
        fp = reduced_static_force(system, q_ref, red, xv + e, t, z)[0]
        fm = reduced_static_force(system, q_ref, red, xv - e, t, z)[0]
        D[:, k] = (fp - fm) / (2.0 * h[k])
    return D


def _check(system, q_guess):
    q = np.asarray(q_guess, dtype=float)
    if q.shape != (system.mechanism.n,) or not np.all(np.isfinite(q)):
        raise ConfigError(f"static_equilibrium: q_guess: expected {system.mechanism.n} finite "
                          f"values, got shape {q.shape}")
    for f in system.forces:
        f.validate(system)
    return q


def _scale(system, q, red, t, z=None) -> float:
    """Force scale of the convergence test: |B^T Q_gravity| + |B^T Q_rest| + 1 N."""
    B = velocity_transform(system, q, red)
    Qg = gravity_force(system, evaluate_tree(system.mechanism, q), q)
    rest = static_forces(system, q, t, z=z) - Qg
    return np.abs(B.T @ Qg).max(initial=0) + np.abs(B.T @ rest).max(initial=0) + 1.0


def _line_search(system, q, red, xv, dx, f, t, z=None):
    """Halve the Newton step while |f| grows; (step, f, q) or None if it leaves the domain."""
    step = 1.0
    for _ in range(10):
        try:
            f_new, q_new = reduced_static_force(system, q, red, xv + step * dx, t, z)
        except (ClosureError, SingularConfigurationError):
            f_new = None
        if f_new is not None and np.linalg.norm(f_new) <= np.linalg.norm(f) * (1 + 1e-12):
            return step, f_new, q_new
        step *= 0.5
    return None if f_new is None else (step * 2.0, f_new, q_new)


def trapped_states(system, q_ref: np.ndarray, z_ref: np.ndarray, t: float = 0.0):
    """The force elements' states as a function of q (n,) -> (nz,), from z_ref (nz,) at
    q_ref (n,): each element's ``trapped_states`` (a hydraulic cylinder behind a closed
    valve: its chambers' pressures follow the stroke, the oil compressed or relieved),
    an element without one keeping its states."""
    z_ref = np.asarray(z_ref, dtype=float)
    if z_ref.shape != (len(system.state_names),):
        raise ConfigError(f"trapped states: z: expected {len(system.state_names)} values "
                          f"({list(system.state_names)}), got shape {z_ref.shape}")
    laws = [(sl, f.trapped_states(system, q_ref, z_ref[sl], t))
            for f, sl in system.state_slices if hasattr(f, "trapped_states")]

    def states(q):
        z = z_ref.copy()
        for sl, law in laws:
            z[sl] = law(q)
        return z
    return states


def static_equilibrium(system, q_guess: np.ndarray, *, t: float = 0.0, hold=(),
                       tol: float = 1e-10, max_iter: int = 30,
                       z: np.ndarray | None = None, trapped: bool = False) -> StaticResult:
    """Static equilibrium near q_guess (drivers at time t; ``hold``: names held fixed;
    force elements with states of their own held at the states z (nz,), e.g. given
    cylinder pressures; without z such an element refuses). With ``trapped`` the states
    z are those at q_guess and follow q as :func:`trapped_states` says (oil sealed behind
    a closed valve: the statics finds where its compression holds the load).

    Converged when |f| <= tol * (|B^T Q_gravity| + |B^T Q_elements| + 1 N).
    Newton steps are halved while |f| grows (up to 10 times). Failure (no
    assembly, singular tangent, no convergence) is a status on the result.

    Raises
    ------
    ConfigError
        Bad q_guess or force element.
    """
    q = _check(system, q_guess)
    try:
        q, red = reduced_coordinates(system, q, hold)
    except (ClosureError, SingularConfigurationError) as exc:
        return StaticResult(q, (), np.zeros(0), np.zeros((0, 0)), np.zeros_like(q), 0, False,
                            f"cannot assemble the start: {exc}")
    names = tuple(system.mechanism.coordinates[i] for i in red.x)
    xv = q[red.x].copy()
    if trapped:
        if z is None:
            raise ConfigError("static_equilibrium: trapped: expected the states z the oil is "
                              "trapped at (at q_guess)")
        z = trapped_states(system, q, z, t)
    f, q = reduced_static_force(system, q, red, xv, t, z)
    D, msg = np.zeros((xv.size, xv.size)), None
    for it in range(max_iter + 1):
        scale = _scale(system, q, red, t, z)
        try:
            D = tangent(system, q, red, xv, t, z)
            if np.abs(f).max(initial=0) <= tol * scale or it == max_iter:
                break  # converged (a neutral direction, e.g. a free slide, is fine here)
            dx = np.linalg.solve(D, -f)
        except (np.linalg.LinAlgError, ClosureError, SingularConfigurationError) as exc:
            msg = f"Newton failed: {exc}"
            break
        found = _line_search(system, q, red, xv, dx, f, t, z)
        if found is None:
            msg = "Newton step leaves the assembly domain"
            break
        step, f, q = found
        xv = xv + step * dx
    ok = msg is None and bool(np.abs(f).max(initial=0) <= tol * scale)
    if msg is None:
        msg = "converged" if ok else (f"not converged after {max_iter} iterations: |f| = "
                                      f"{np.abs(f).max():.3e}")
    zq = z(q) if callable(z) else (None if z is None else np.asarray(z, dtype=float))
    return StaticResult(q, names, f, -D, static_forces(system, q, t, z=z), it, ok, msg, red,
                        zq)
