"""Linearised vibration about a static equilibrium (DESIGN §4, analyses).

In the independent coordinates x of :mod:`pipeline.dynamics.statics` (free
joint coordinates + modal coordinates; drivers and ``hold`` held fixed):

    M_r dx'' + C_r dx' + K_r dx = 0,
    M_r = B^T M B,  K_r = -d(B^T Q)/dx (central differences, loops closed),
    C_r = -B^T (dQ/dq') B  (modal damping and the force elements' dampers),

with B = dq/dx. At an equilibrium q' = 0, so h (quadratic in q') has no
linear part. Undamped: generalized symmetric eigenproblem K phi = w^2 M phi;
damped: first-order form, lambda = -zeta w_n +- i w_n sqrt(1 - zeta^2).

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

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from pipeline.core.errors import ConfigError
from pipeline.dynamics.equations import elastic_forces
from pipeline.dynamics.mass_matrix import mass_matrix
from pipeline.dynamics.statics import reduced_coordinates, tangent, velocity_transform
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
    """

    omega: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    shapes_q: np.ndarray
    model: LinearModel


def _damping(system, q, B, t):
    """-B^T dQ/dq' B by central differences along the columns of B (linear for dampers)."""
    tree = evaluate_tree(system.mechanism, q)

    def Qv(qd):
        Q = elastic_forces(system, q, qd)[1]
        for f in system.forces:
            Q = Q + f.generalized_force(system, tree, q, qd, t)
        return Q

    h = 1e-6
    cols = [(Qv(h * b) - Qv(-h * b)) / (2 * h) for b in B.T]
    D = np.array(cols).T if cols else np.zeros((q.size, 0))
    return -B.T @ D


def linearize(system, q_eq: np.ndarray, *, t: float = 0.0, hold=()) -> LinearModel:
    """Reduced M, C, K about the equilibrium q_eq (n,) (e.g. ``static_equilibrium(...).q``)."""
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
    B = velocity_transform(system, q, red)
    M = B.T @ mass_matrix(system, evaluate_tree(system.mechanism, q), q) @ B
    K = -tangent(system, q, red, q[red.x].copy(), t)
    C = _damping(system, q, B, t)
    names = tuple(system.mechanism.coordinates[i] for i in red.x)
    return LinearModel(q, names, B, 0.5 * (M + M.T), C, K)


def _normalise(V: np.ndarray) -> np.ndarray:
    idx = np.argmax(np.abs(V), axis=0)
    return V / V[idx, np.arange(V.shape[1])]


def vibration_modes(system, q_eq: np.ndarray, *, t: float = 0.0, hold=()) -> VibrationModes:
    """Frequencies, damping ratios and mode shapes about the equilibrium q_eq."""
    lm = linearize(system, q_eq, t=t, hold=hold)
    k = lm.M.shape[0]
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


def marker_motion(system, modes: VibrationModes, link: str, frame: str) -> np.ndarray:
    """(3, k) translation of marker ``frame`` on ``link`` per mode (ground axes, m per unit
    mode amplitude): dR/dq @ shapes_q."""
    q = modes.model.q
    tree = evaluate_tree(system.mechanism, q)
    sv = step_value(system.mechanism.marker(link, frame), tree.A, tree.dA, None, None, q)
    return sv.dP[:, :3, 3].T @ modes.shapes_q
