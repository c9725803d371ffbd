"""Flat arrays of a System for the compiled index-3 step (:mod:`pipeline.solver.dae_kernels`).

Everything the constrained equations need besides time-dependent inputs: the compiled
mechanism and masses, modal stiffness and damping, row weights, the driven (P) and integrated
(U) coordinates, and the force elements in their compiled form
(:mod:`pipeline.dynamics.forces.compiled`: every built-in element has one; a user's own
element class is called back in Python from the same compiled step, and the log says so).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from pipeline.dynamics.forces.compiled import compile_forces, uncompiled
from pipeline.dynamics.forces.compiled import force_factors as _factors
from pipeline.dynamics.forces.markers import ForceData

logger = logging.getLogger(__name__)

__all__ = ["CompiledDae", "compile_dae", "derivatives_needed", "force_factors"]


@dataclass(frozen=True)
class CompiledDae:
    """Flat data of a system (see the module docstring).

    kin, masses : the CompiledMechanism and CompiledMasses.  K, D : (n, n) modal stiffness
    and damping.  w : (m,) row weights.  U, P : integrated and driven coordinates.
    unit : (n,) natural coordinate units.  gravity4 : (4,).  forces : the force elements'
    ForceData.  histories : per force element, its history object or None (the caller's
    factors).
    """

    kin: object
    masses: object
    K: np.ndarray
    D: np.ndarray
    w: np.ndarray
    U: np.ndarray
    P: np.ndarray
    unit: np.ndarray
    gravity4: np.ndarray
    forces: ForceData
    histories: tuple


def compile_dae(system, U: np.ndarray, P: np.ndarray, warn: bool = True) -> CompiledDae:
    """The flat data of ``system``; an element without a compiled form is logged (unless
    ``warn`` is False: a run that already said it)."""
    mech = system.mechanism
    python = uncompiled(system.forces)
    if python:
        (logger.info if warn else logger.debug)(
            "force element(s) %s have no compiled form: the compiled step calls their "
            "numpy methods back (docs/force_elements.md)", python)
    forces, histories = compile_forces(system)
    K, D = system.modal_stiffness_damping
    return CompiledDae(
        derivatives_needed(mech.compiled, forces, bool(python)), system.compiled_masses,
        np.ascontiguousarray(K), np.ascontiguousarray(D),
        np.array(mech.row_weights, dtype=float),
        np.asarray(U, dtype=np.int64), np.asarray(P, dtype=np.int64),
        np.array(mech.coordinate_units, dtype=float), np.array(system.gravity4, dtype=float),
        forces, histories)


def derivatives_needed(kin, forces: ForceData, python: bool):
    """``kin`` (a CompiledMechanism) with dA complete only where the equations of motion
    read it: the links of the force elements' markers (and the loops' ends; every link
    when an element is called back in Python: it may read any)."""
    return kin if python else kin.derivatives_for(forces.link)


def force_factors(data: CompiledDae, times: np.ndarray) -> np.ndarray:
    """(k, F): each force element's history value at the times (k,) s (1 without one)."""
    return _factors(data.histories, times)
