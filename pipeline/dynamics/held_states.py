"""The force elements' states that hold a machine at rest where it starts: a hydraulic
cylinder's ``hold`` pressure (the valve closed on a loaded boom: its piston side carries
what the boom weighs on it).

The open states z_K (NaN in the elements' start values) enter the generalized forces
linearly (a pressure on an area), Q(z) = Q(z_0) + sum_k dQ/dz_k z_k, so at rest at q the
balance on the joint coordinates J that are neither driven nor modal is

    rhs_J(q, 0, z_0) + sum_k (dQ/dz_k)_J z_k + C_J^T lambda = 0,

a linear least-squares problem in (z_K, lambda) (C: the loops' closure Jacobian). The
modal coordinates are left out: flexible links start undeformed, as given, and their
modes ring from there, moving the joints with them through the mass matrix (a static
start, ``static_equilibrium(..., z=z)``, deflects them under the held pressures). A
balance the open states cannot meet (a motion no holding element resists) is a
ConfigError naming the coordinates left unbalanced.
"""

from __future__ import annotations

import logging

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics.equations import equation_terms
from pipeline.kinematics.closure import closure

__all__ = ["held_states"]

logger = logging.getLogger(__name__)


def held_states(system, q, t: float, z: np.ndarray) -> np.ndarray:
    """z (nz,) with its NaN entries set to the values that hold ``system`` at rest at q
    (n,) and time t, s (module docstring)."""
    names = system.state_names
    open_ = np.flatnonzero(np.isnan(z))
    if q is None:
        raise ConfigError(f"the states {[names[k] for k in open_]} are found at the start "
                          f"(hold): the start coordinates are needed")
    mech = system.mechanism
    q = np.asarray(q, dtype=float)
    v = np.zeros_like(q)
    z0 = np.where(np.isnan(z), 0.0, z)
    base = equation_terms(system, q, v, t, z=z0)
    scales = system.state_scales()
    cols = []
    for k in open_:
        dz = np.zeros_like(z0)
        dz[k] = scales[k]
        cols.append((equation_terms(system, q, v, t, z=z0 + dz).Q_forces - base.Q_forces)
                    / scales[k])
    modal = np.concatenate([np.zeros(0, dtype=int), *mech.modal_index]).astype(int)
    driven = mech.indices(list(system.drivers)) if system.drivers else np.zeros(0, dtype=int)
    J = np.setdiff1d(np.arange(mech.n), np.concatenate([modal, driven]))
    A = np.column_stack(cols)[J]
    if mech.topology.loops:
        A = np.column_stack([A, closure(mech, q).J[:, J].T])
    b = -base.rhs[J]
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    left = A @ x - b
    scale = max(np.abs(b).max(initial=0.0), np.abs(A[:, :open_.size] @ x[:open_.size]).max(
        initial=0.0), 1e-12)
    if np.abs(left).max(initial=0.0) > 1e-8 * scale:
        worst = [mech.coordinates[J[i]] for i in np.argsort(-np.abs(left))[:3]
                 if abs(left[i]) > 1e-8 * scale]
        raise ConfigError(
            f"the held states {[names[k] for k in open_]} cannot hold the machine at rest at "
            f"its start: {np.abs(left).max():.3g} N (N m) left unbalanced on {worst}, a "
            f"motion no holding element resists; give those coordinates a driver, or the "
            f"states values")
    z = z0.copy()
    z[open_] = x[:open_.size]
    logger.info("held at the start: %s", ", ".join(
        f"{names[k]} = {z[k]:.6g}" for k in open_))
    return z
