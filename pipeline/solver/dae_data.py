"""Flat arrays of a System for the compiled index-3 step (:mod:`pipeline.solver.dae_kernels`).

Everything the constrained equations need besides time-dependent inputs: the compiled
mechanism and masses, modal stiffness and damping, row weights, the driven (P) and integrated
(U) coordinates, and the force elements that have a compiled form. Those are

* kind 0, a joint spring-damper:  Q_k = -k (q_k - q0) - c q_k';
* kind 1, a force along a coordinate: Q_k = F * factor (a force cylinder, a motor torque);
* kind 2, a spring-damper between two marker points: tension = preload + k (l - l0) + c l',
  Q = -tension dl/dq;
* kind 3, a force fixed in ground axes at a marker point: Q = (dR/dq) F * factor;

with ``factor`` a time history's value, evaluated by the caller at the step's end (1 without
one). A system with any other element (tables, follower forces, torques, user elements) has
no compiled form: :func:`compile_dae` returns None and the numpy step runs instead.

A marker point is R = A_l (c0 + sum_a eta_a c_a) with c0 = r0 + R0 o and c_a = phi_a +
psi_a x (R0 o) (the first-order shape matrix applied to the offset o in the frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.dynamics.forces.loads import ForceCylinder, JointForce, PointForce, history_value
from pipeline.dynamics.forces.springs import JointSpringDamper, SpringDamper

__all__ = ["CompiledDae", "compile_dae", "force_factors"]


@dataclass(frozen=True)
class CompiledDae:
    """Flat data of a system (see the module docstring).

    kin, masses : the CompiledMechanism and CompiledMasses.  K, D : (n, n) modal stiffness
    and damping.  w : (m,) row weights.  U, P : integrated and driven coordinates.
    unit : (n,) natural coordinate units.  gravity4 : (4,).
    fkind (F,), fint (F, 4) [coordinate or marker a, marker b, ...], fpar (F, 6)
    [k, q0 or l0, c, preload or F, Fy, Fz], fcons (F,) conservative flag.
    mlink (Mk,), mc0 (Mk, 3), mca (Mk, MM, 3), midx (Mk, MM), mnm (Mk,), mhe (Mk, MM, MM,
    3), mhn (Mk,): marker points, c0 + sum_a q_a ca_a + sum_ab q_a q_b he_ab / 2 in their
    link's frame (he: the second-order translation of the frame they sit on; mhn its
    number of modes, 0 for a first-order frame, whose kernels then skip the terms).
    histories : per force element, its history object or None (the caller's factors).
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
    fkind: np.ndarray
    fint: np.ndarray
    fpar: np.ndarray
    fcons: np.ndarray
    mlink: np.ndarray
    mc0: np.ndarray
    mca: np.ndarray
    midx: np.ndarray
    mnm: np.ndarray
    mhe: np.ndarray
    mhn: np.ndarray
    histories: tuple


def _marker(mech, marker, offset, MM):
    link, frame = marker
    li = mech.link_index(link)
    f = mech.links[li].frame(frame)
    o = f.pose[:3, :3] @ np.asarray(offset, dtype=float)
    c0 = f.pose[:3, 3] + o
    idx = mech.modal_index[li]
    ca, he = np.zeros((MM, 3)), np.zeros((MM, MM, 3))
    if idx.size:
        ca[:idx.size] = f.phi + np.cross(f.psi, o)
        if f.hess is not None:  # the frame's second-order translation (rotations: first order)
            he[:idx.size, :idx.size] = f.hess
    mi = np.zeros(MM, dtype=np.int64)
    mi[:idx.size] = idx
    return li, c0, ca, mi, idx.size, he, idx.size if f.hess is not None else 0


def compile_dae(system, U: np.ndarray, P: np.ndarray) -> CompiledDae | None:
    """The flat data of ``system``, or None when a force element has no compiled form."""
    mech = system.mechanism
    MM = max([1] + [len(i) for i in mech.modal_index])
    kinds, ints, pars, cons, hist, markers = [], [], [], [], [], []
    for f in system.forces:
        t = type(f)
        if t is JointSpringDamper:
            kinds.append(0)
            ints.append([mech.index(f.coordinate), 0, 0, 0])
            pars.append([f.stiffness, f.free_value, f.damping, 0.0, 0.0, 0.0])
            hist.append(None)
        elif t in (JointForce, ForceCylinder):
            kinds.append(1)
            ints.append([mech.index(f.coordinate), 0, 0, 0])
            pars.append([0.0, 0.0, 0.0, float(f.force), 0.0, 0.0])
            hist.append(f.history)
        elif t is SpringDamper:
            kinds.append(2)
            ints.append([len(markers), len(markers) + 1, 0, 0])
            markers += [_marker(mech, f.marker_a, (0, 0, 0), MM),
                        _marker(mech, f.marker_b, (0, 0, 0), MM)]
            pars.append([f.stiffness, f.free_length, f.damping, f.preload, 0.0, 0.0])
            hist.append(None)
        elif t is PointForce:
            kinds.append(3)
            ints.append([len(markers), 0, 0, 0])
            markers.append(_marker(mech, f.marker, f.offset, MM))
            pars.append([0.0, 0.0, 0.0, *np.asarray(f.force, dtype=float)])
            hist.append(f.history)
        else:  # tables, follower forces, torques, user elements: the numpy step
            return None
        cons.append(bool(f.conservative))
    K, D = system.modal_stiffness_damping
    nm = len(markers)
    return CompiledDae(
        mech.compiled, system.compiled_masses, np.ascontiguousarray(K),
        np.ascontiguousarray(D), np.array(mech.row_weights, dtype=float),
        np.asarray(U, dtype=np.int64), np.asarray(P, dtype=np.int64),
        np.array(mech.coordinate_units, dtype=float), np.array(system.gravity4, dtype=float),
        np.array(kinds, dtype=np.int64).reshape(-1), np.array(ints, dtype=np.int64).reshape(-1, 4),
        np.array(pars, dtype=float).reshape(-1, 6), np.array(cons, dtype=np.bool_).reshape(-1),
        np.array([m[0] for m in markers], dtype=np.int64).reshape(nm),
        np.array([m[1] for m in markers], dtype=float).reshape(nm, 3),
        np.array([m[2] for m in markers], dtype=float).reshape(nm, MM, 3),
        np.array([m[3] for m in markers], dtype=np.int64).reshape(nm, MM),
        np.array([m[4] for m in markers], dtype=np.int64).reshape(nm),
        np.array([m[5] for m in markers], dtype=float).reshape(nm, MM, MM, 3),
        np.array([m[6] for m in markers], dtype=np.int64).reshape(nm), tuple(hist))


def force_factors(data: CompiledDae, times: np.ndarray) -> np.ndarray:
    """(k, F): each force element's history value at the times (k,) s (1 without one)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    out = np.ones((times.size, len(data.histories)))
    for j, h in enumerate(data.histories):
        if h is not None:
            out[:, j] = [history_value(h, float(x), "history") for x in times]
    return out
