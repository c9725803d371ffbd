"""The force elements of a system in compiled form: packed into one :class:`~pipeline.
dynamics.forces.markers.ForceData` and evaluated by the kernels their own modules define.

Every built-in element class declares its ``KIND`` and ``pack(mech, markers)`` (its rows of
the flat data) next to its numpy methods, and the module defines its compiled kernels;
:data:`KERNELS` names them per kind, and the two dispatchers below call them. A new element
kind adds its class with ``KIND``, ``pack`` and its two kernels in its module (three with
states of its own: their rates), and one branch in each dispatcher (numba calls compiled
functions only by name);
``tests/solver/test_compiled_step.py`` fails for a built-in element class without them.
An element without a compiled form (a user's own class) is packed as
:data:`~pipeline.dynamics.forces.python_elements.PYTHON_KIND`: the dispatchers call its
numpy methods back (:mod:`.python_elements`), inside the same compiled step.
"""

from __future__ import annotations

import numpy as np
from numba import njit, objmode

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.dynamics.forces import hydraulics as H
from pipeline.dynamics.forces import loads as L
from pipeline.dynamics.forces import python_elements as P
from pipeline.dynamics.forces import springs as S
from pipeline.dynamics.forces.loads import history_value
from pipeline.dynamics.forces.markers import ForceData, MarkerTable

__all__ = ["KERNELS", "compile_forces", "force_factors", "generalized_forces", "has_kernels",
           "potential", "state_rates", "uncompiled"]

JOINT_SPRING = S.JointSpringDamper.KIND
COORDINATE_FORCE = L.JointForce.KIND
LINE_SPRING = S.SpringDamper.KIND
POINT_FORCE = L.PointForce.KIND
TABLE_SPRING = S.TableSpringDamper.KIND
FOLLOWER_FORCE = L.FollowerForce.KIND
LINE_FORCE = L.LineForce.KIND
TORQUE = L.Torque.KIND
HYDRAULIC_CYLINDER = H.HydraulicCylinder.KIND
PYTHON_KIND = P.PYTHON_KIND

#: kind -> (element classes, force kernel, potential kernel[, state-rate kernel]): an
#: element with states of its own (contract rule 7) has its rates' kernel, and its force
#: kernel takes the states z after v
KERNELS = {
    JOINT_SPRING: ((S.JointSpringDamper,), S.joint_spring_force, S.joint_spring_potential),
    COORDINATE_FORCE: ((L.JointForce, L.ForceCylinder), L.coordinate_force,
                       L.coordinate_potential),
    LINE_SPRING: ((S.SpringDamper,), S.line_spring_force, S.line_spring_potential),
    POINT_FORCE: ((L.PointForce,), L.point_force, L.point_potential),
    TABLE_SPRING: ((S.TableSpringDamper,), S.table_spring_force, S.table_spring_potential),
    FOLLOWER_FORCE: ((L.FollowerForce,), L.follower_force, L.no_potential),
    LINE_FORCE: ((L.LineForce,), L.line_force, L.line_potential),
    TORQUE: ((L.Torque,), L.torque, L.no_potential),
    HYDRAULIC_CYLINDER: ((H.HydraulicCylinder,), H.cylinder_force, L.no_potential,
                         H.cylinder_rates),
}


def has_kernels(f) -> bool:
    """Does force element ``f`` have a compiled form (its exact class registered)?"""
    return type(f) in KERNELS.get(getattr(type(f), "KIND", None), ((),))[0]


def uncompiled(forces) -> list[str]:
    """The names of the elements among ``forces`` that have no compiled form."""
    return [getattr(f, "name", type(f).__name__) for f in forces if not has_kernels(f)]


def compile_forces(system) -> tuple[ForceData, tuple]:
    """(the flat data of ``system.forces``, each element's history, None, or
    :data:`~.python_elements.TIME` for an element without a compiled form)."""
    mech = system.mechanism
    markers = MarkerTable(mech)
    kinds, ints, pars, cons, tables, hist = [], [], [], [], [], []
    rows = 0
    offsets = {id(f): sl.start for f, sl in system.state_slices}
    python = []  # (row, element) of the elements evaluated by their numpy methods
    for f in system.forces:
        if not has_kernels(f):
            python.append((len(kinds), f))
            kinds.append(PYTHON_KIND)
            ints.append([0, 0, 0, 0, offsets.get(id(f), -1)])
            pars.append([])
            cons.append(bool(getattr(f, "conservative", False)))
            hist.append(P.TIME)
            continue
        i, p, table = f.pack(mech, markers)
        if table is not None:
            i = [i[0], i[1], rows, len(table)]
            tables.append(np.asarray(table, dtype=float))
            rows += len(table)
        kinds.append(type(f).KIND)
        ints.append(list(i) + [offsets.get(id(f), -1)])
        pars.append(list(p))
        cons.append(bool(f.conservative))
        hist.append(getattr(f, f.HISTORY, None))
    table = np.concatenate(tables) if tables else np.zeros((0, 3))
    width = max([6] + [len(p) for p in pars])
    par = np.zeros((len(pars), width))
    for e, p in enumerate(pars):
        par[e, :len(p)] = p
    data = ForceData(np.array(kinds, dtype=np.int64).reshape(-1),
                     np.array(ints, dtype=np.int64).reshape(-1, 5), par,
                     np.array(cons, dtype=np.bool_).reshape(-1), table, *markers.arrays())
    for row, f in python:
        data.ints[row, 0] = P.register(system, f, data.ints)
    return data, tuple(hist)


def force_factors(histories: tuple, times: np.ndarray) -> np.ndarray:
    """(k, 2F): each force element's history value at the times (k,) s (1 without one),
    then the rates a controller's feed-forward reads (its reference's; 0 elsewhere)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    F = len(histories)
    out = np.ones((times.size, 2 * F))
    out[:, F:] = 0.0
    for j, h in enumerate(histories):
        if h is P.TIME:
            out[:, j] = times
            out[:, F + j] = 1.0
        elif h is not None:
            out[:, j] = [history_value(h, float(x), "history") for x in times]
            if isinstance(h, H.PID) and h.feedforward:
                out[:, F + j] = [h.rate(float(x)) for x in times]
    return out


@njit(cache=True)
def generalized_forces(q, v, z, A, dA, factor, d, Q, Qnc):
    """Add every element's generalized force to Q (n,) and its non-conservative part to
    Qnc (n,) at (q, v) and the elements' states z (nz,) with the link poses A, dA and the
    history factors (F,)."""
    for e in range(d.kind.shape[0]):
        kind = d.kind[e]
        if kind == JOINT_SPRING:
            S.joint_spring_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == COORDINATE_FORCE:
            L.coordinate_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == LINE_SPRING:
            S.line_spring_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == POINT_FORCE:
            L.point_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == TABLE_SPRING:
            S.table_spring_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == FOLLOWER_FORCE:
            L.follower_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == LINE_FORCE:
            L.line_force(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == TORQUE:
            L.torque(e, q, v, A, dA, factor, d, Q, Qnc)
        elif kind == HYDRAULIC_CYLINDER:
            H.cylinder_force(e, q, v, z, A, dA, factor, d, Q, Qnc)
        elif kind == PYTHON_KIND:
            key, t = d.ints[e, 0], factor[e]
            with objmode():
                P.element_force(key, q, v, z, A, dA, t, Q, Qnc)


@njit(cache=True)
def state_rates(q, v, z, A, dA, factor, d, zd):
    """zd (nz,) = the rates of the elements' own states at (q, v, z)."""
    for e in range(d.kind.shape[0]):
        if d.kind[e] == HYDRAULIC_CYLINDER:
            H.cylinder_rates(e, q, v, z, A, dA, factor, d, zd)
        elif d.kind[e] == PYTHON_KIND and d.ints[e, 4] >= 0:
            key, t = d.ints[e, 0], factor[e]
            with objmode():
                P.element_rates(key, q, v, z, A, dA, t, zd)


@njit(cache=True)
def potential(q, A, dA, d):
    """Potential energy (J) of the conservative elements."""
    V = 0.0
    for e in range(d.kind.shape[0]):
        kind = d.kind[e]
        if kind == JOINT_SPRING:
            V += S.joint_spring_potential(e, q, A, dA, d)
        elif kind == COORDINATE_FORCE:
            V += L.coordinate_potential(e, q, A, dA, d)
        elif kind == LINE_SPRING:
            V += S.line_spring_potential(e, q, A, dA, d)
        elif kind == POINT_FORCE:
            V += L.point_potential(e, q, A, dA, d)
        elif kind == TABLE_SPRING:
            V += S.table_spring_potential(e, q, A, dA, d)
        elif kind == LINE_FORCE:
            V += L.line_potential(e, q, A, dA, d)
        elif kind == PYTHON_KIND:
            key = d.ints[e, 0]
            with objmode(x="float64"):
                x = P.element_potential(key, q, A, dA)
            V += x
    return V
