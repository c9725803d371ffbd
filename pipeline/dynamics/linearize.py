"""Linearised vibration about a static equilibrium (DESIGN §4, analyses).

In the independent coordinates x of :mod:`pipeline.dynamics.statics` (free
joint coordinates + modal coordinates; drivers and ``hold`` held fixed):

    M_r dx'' + C_r dx' + K_r dx = 0,
    M_r = B^T M B,  K_r = -d(B^T Q)/dx (central differences, loops closed),
    C_r = -B^T (dQ/dq') B  (modal damping and the force elements' dampers),

with B = dq/dx. At an equilibrium q' = 0, so h (quadratic in q') has no
linear part. Undamped: generalized symmetric eigenproblem K phi = w^2 M phi;
damped: first-order form, lambda = -zeta w_n +- i w_n sqrt(1 - zeta^2).

Force elements with states of their own (a hydraulic cylinder's chamber pressures z,
rates z' = r(q, q', z)) add their coupling, all by central differences at the
equilibrium (q_eq, z_eq):

    M dx'' + C dx' + K dx = G dz,     G = B^T dQ/dz,
    dz' = S_x dx + S_v dx' + S_z dz,  S_x = dr/dx (loops closed), S_v = dr/dq' B,
                                      S_z = dr/dz,

so the oil columns' stiffness enters the frequencies (first-order form always). A state
that only integrates the motion (the oil trapped behind a closed valve: its mass is
conserved) gives a neutral direction, eigenvalue 0: it is a family of equilibria, not a
vibration, and is left out of the modes -- as is, in this form, any other eigenvalue 0
(a coordinate nothing holds, which the form without states lists at frequency 0).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.dynamics import BodyMass, System
>>> from pipeline.dynamics.forces import JointSpringDamper
>>> mech = build_mechanism([rigid_link("ground"), rigid_link("disk")],
...                        [Joint("pin", "revolute", "ground", "body", "disk", "body")])
>>> s = System(mech, {"disk": BodyMass.rigid(1.0, [0, 0, 0], np.diag([1, 1, 0.25]))},
...            [0, 0, 0], forces=[JointSpringDamper("k", "pin.theta", stiffness=100.0)])
>>> m = vibration_modes(s, np.zeros(1))
>>> round(float(m.omega[0]), 6)  # sqrt(k / I)
20.0
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla

from pipeline.core.errors import ConfigError
from pipeline.dynamics.equations import elastic_forces, state_rates
from pipeline.dynamics.mass_matrix import mass_matrix
from pipeline.dynamics.statics import (
    fd_steps,
    place,
    reduced_coordinates,
    static_forces,
    tangent,
    velocity_transform,
)
from pipeline.kinematics import evaluate_tree
from pipeline.kinematics.poses import step_value

__all__ = ["LinearModel", "VibrationModes", "linearize", "marker_motion", "vibration_modes"]


@dataclass(frozen=True)
class LinearModel:
    """Reduced linear model about q (k = number of independent coordinates).

    Attributes
    ----------
    q : (n,) equilibrium.  coordinates : names of x.
    B : (n, k) dq/dx.  M, C, K : (k, k) mass, damping, tangent stiffness.
    """

    q: np.ndarray
    coordinates: tuple[str, ...]
    B: np.ndarray
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    #: the elements' states (module docstring): names, z_eq (nz,), G (k, nz), S (nz, 2k + nz)
    state_names: tuple[str, ...] = ()
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G: np.ndarray | None = None
    S: np.ndarray | None = None


@dataclass(frozen=True)
class VibrationModes:
    """Modes sorted by undamped natural frequency.

    Attributes
    ----------
    omega : (k,) natural frequencies w_n, rad/s (NaN for an unstable direction).
    frequencies_hz : (k,) damped frequencies w_n sqrt(1 - zeta^2) / 2 pi, Hz.
    damping_ratios : (k,) zeta (0 undamped; >= 1 overdamped, frequency 0).
    shapes : (k, k) mode shapes in x (columns; complex if damped), max |entry| 1.
    shapes_q : (n, k) the same in all coordinates (B shapes).
    model : the LinearModel.
    shapes_z : (nz, k) the elements' states in each mode (same scaling as ``shapes``).

    With element states there are m modes (one per conjugate pair of eigenvalues, one per
    real eigenvalue but the neutral ones) instead of k, and the arrays are (m,), (k, m),
    (n, m), (nz, m).
    """

    omega: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    shapes_q: np.ndarray
    model: LinearModel
    shapes_z: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


def _damping(system, q, B, t, z=None):
    """-B^T dQ/dq' B by central differences along the columns of B (linear for dampers)."""
    tree = evaluate_tree(system.mechanism, q)

    def Qv(qd):
        return elastic_forces(system, q, qd)[1] \
            + system.compiled_forces.forces(tree, q, qd, t, z)[0]

    h = 1e-6
    cols = [(Qv(h * b) - Qv(-h * b)) / (2 * h) for b in B.T]
    D = np.array(cols).T if cols else np.zeros((q.size, 0))
    return -B.T @ D


def linearize(system, q_eq: np.ndarray, *, t: float = 0.0, hold=(),
              z_eq: np.ndarray | None = None) -> LinearModel:
    """Reduced M, C, K about the equilibrium q_eq (n,) (e.g. ``static_equilibrium(...).q``)
    and, for force elements with states, their coupling G, S about z_eq (nz,) (default:
    the elements' start values, a ``hold`` pressure found to hold q_eq; module
    docstring)."""
    q_eq = np.asarray(q_eq, dtype=float)
    if q_eq.shape != (system.mechanism.n,) or not np.all(np.isfinite(q_eq)):
        raise ConfigError(f"linearize: q_eq: expected {system.mechanism.n} finite values, "
                          f"got shape {q_eq.shape}")
    for f in system.forces:
        f.validate(system)
    q, red = reduced_coordinates(system, q_eq, hold)
    if red.x.size == 0:
        raise ConfigError("linearize: no independent coordinates left (everything driven or "
                          "held)")
    z = _equilibrium_states(system, q, t, z_eq)
    B = velocity_transform(system, q, red)
    M = B.T @ mass_matrix(system, evaluate_tree(system.mechanism, q), q) @ B
    K = -tangent(system, q, red, q[red.x].copy(), t, z)
    C = _damping(system, q, B, t, z)
    names = tuple(system.mechanism.coordinates[i] for i in red.x)
    lm = LinearModel(q, names, B, 0.5 * (M + M.T), C, K)
    if z is None:
        return lm
    G, S = _state_coupling(system, q, red, B, t, z)
    return replace(lm, state_names=system.state_names, z=z, G=G, S=S)


def _equilibrium_states(system, q, t, z_eq):
    """The states to linearise about: z_eq checked, or the elements' start values at q
    (None when no element has states)."""
    nz = len(system.state_names)
    if not nz:
        if z_eq is not None and np.size(z_eq):
            raise ConfigError("linearize: z_eq: the force elements have no states")
        return None
    if z_eq is None:
        return system.initial_states(q, t)
    z = np.asarray(z_eq, dtype=float)
    if z.shape != (nz,) or not np.all(np.isfinite(z)):
        raise ConfigError(f"linearize: z_eq: expected {nz} finite values "
                          f"({', '.join(system.state_names)}), got {z_eq!r}")
    return z


def _state_coupling(system, q, red, B, t, z):
    """G = B^T dQ/dz (k, nz) and S = [dr/dx, dr/dq' B, dr/dz] (nz, 2k + nz) by central
    differences at (q, q' = 0, z) (module docstring)."""
    k, nz = B.shape[1], z.size
    v0 = np.zeros_like(q)
    hz = 1e-6 * system.state_scales()
    G = np.empty((k, nz))
    Sz = np.empty((nz, nz))
    for j in range(nz):
        e = np.zeros(nz)
        e[j] = hz[j]
        G[:, j] = B.T @ (static_forces(system, q, t, z=z + e)
                         - static_forces(system, q, t, z=z - e)) / (2 * hz[j])
        Sz[:, j] = (state_rates(system, q, v0, t, z + e)
                    - state_rates(system, q, v0, t, z - e)) / (2 * hz[j])
    xv = q[red.x].copy()
    hx = fd_steps(system, red, xv)
    Sx, Sv = np.empty((nz, k)), np.empty((nz, k))
    for i in range(k):
        e = np.zeros(k)
        e[i] = hx[i]
        qp, qm = place(system, q, red, xv + e, t), place(system, q, red, xv - e, t)
        Sx[:, i] = (state_rates(system, qp, v0, t, z) - state_rates(system, qm, v0, t, z)) \
            / (2 * hx[i])
        Sv[:, i] = (state_rates(system, q, hx[i] * B[:, i], t, z)
                    - state_rates(system, q, -hx[i] * B[:, i], t, z)) / (2 * hx[i])
    return G, np.hstack([Sx, Sv, Sz])


def _normalise(V: np.ndarray) -> np.ndarray:
    idx = np.argmax(np.abs(V), axis=0)
    return V / V[idx, np.arange(V.shape[1])]


def vibration_modes(system, q_eq: np.ndarray, *, t: float = 0.0, hold=(),
                    z_eq: np.ndarray | None = None) -> VibrationModes:
    """Frequencies, damping ratios and mode shapes about the equilibrium q_eq (and the
    elements' states z_eq, see :func:`linearize`)."""
    lm = linearize(system, q_eq, t=t, hold=hold, z_eq=z_eq)
    k = lm.M.shape[0]
    if lm.S is not None:
        return _state_modes(lm)
    if not np.any(lm.C):
        lam, V = sla.eigh(0.5 * (lm.K + lm.K.T), lm.M)
        omega = np.where(lam >= 0, np.sqrt(np.abs(lam)), np.nan)
        zeta, V = np.zeros(k), _normalise(V)
        f_hz = omega / (2 * np.pi)
    else:
        Minv = np.linalg.inv(lm.M)
        A = np.block([[np.zeros((k, k)), np.eye(k)], [-Minv @ lm.K, -Minv @ lm.C]])
        lam, W = np.linalg.eig(A)
        keep = np.flatnonzero(lam.imag >= 0)  # one of each conjugate pair
        if keep.size > k:  # overdamped pairs give two real roots: keep the slower
            keep = keep[np.argsort(np.abs(lam[keep]))][:k]
        lam, V = lam[keep], _normalise(W[:k, keep])
        omega = np.abs(lam)
        zeta = -lam.real / np.where(omega > 0, omega, 1.0)
        f_hz = np.abs(lam.imag) / (2 * np.pi)
    order = np.argsort(np.nan_to_num(omega, nan=-1.0))
    V = V[:, order]
    return VibrationModes(omega[order], f_hz[order], zeta[order], V, lm.B @ V, lm)


def _state_modes(lm: LinearModel) -> VibrationModes:
    """Modes of the first-order form with the elements' states (module docstring): one per
    conjugate pair and one per real eigenvalue but the neutral ones, sorted by |lambda|."""
    k, nz = lm.M.shape[0], lm.z.size
    Minv = np.linalg.inv(lm.M)
    A = np.block([[np.zeros((k, k)), np.eye(k), np.zeros((k, nz))],
                  [-Minv @ lm.K, -Minv @ lm.C, Minv @ lm.G],
                  [lm.S]])
    lam, W = np.linalg.eig(A)
    scale = max(np.abs(lam).max(initial=0.0), 1.0)
    real = np.abs(lam.imag) <= 1e-9 * scale
    neutral = np.abs(lam) <= 1e-9 * scale
    keep = np.flatnonzero((real | (lam.imag > 0)) & ~neutral)
    lam = np.where(real[keep], lam[keep].real, lam[keep])
    W = W[:, keep]
    omega = np.abs(lam)
    zeta = -lam.real / omega
    f_hz = np.abs(lam.imag) / (2 * np.pi)
    order = np.argsort(omega, kind="stable")
    W = W[:, order]
    big = np.argmax(np.abs(W[:k]), axis=0)
    norm = W[big, np.arange(W.shape[1])]
    W = W / np.where(np.abs(norm) > 0, norm, 1.0)  # the largest coordinate entry 1
    return VibrationModes(omega[order], f_hz[order], zeta[order], W[:k], lm.B @ W[:k], lm,
                          W[2 * k:])


def marker_motion(system, modes: VibrationModes, link: str, frame: str) -> np.ndarray:
    """(3, k) translation of marker ``frame`` on ``link`` per mode (ground axes, m per unit
    mode amplitude): dR/dq @ shapes_q."""
    q = modes.model.q
    tree = evaluate_tree(system.mechanism, q)
    sv = step_value(system.mechanism.marker(link, frame), tree.A, tree.dA, None, None, q)
    return sv.dP[:, :3, 3].T @ modes.shapes_q
